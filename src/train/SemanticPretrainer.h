#pragma once
// RGB encoder pretraining by scene recognition (trainer.task =
// rgb_semantic), the stand-in for the ImageNet classifier whose ResNet
// VLN-CE freezes (paper Section 4).
//
// From one RGB view the network predicts what VLN instructions talk about:
//  - the object categories in view (multi-label over
//    world::houseObjectCategories()): an object is in view when it covers at
//    least pretrain.min_object_fraction of the pixels of the semantic
//    render of the same camera;
//  - the colours of those objects (multi-label over world::houseColorNames());
//  - the type of the room the camera stands in (one of
//    world::houseRoomTypes(); cross-entropy).
// Views are taken at uniformly random points of a house's main navmesh
// island with a uniform heading, the camera sim.rgb.position_y above the
// floor, as the agent's. Every epoch (pretrain.iterations of them) renders
// pretrain.samples fresh views in the training houses, so the network sees
// new images throughout and memory holds one epoch. The network is the RGB
// CNN (model.rgb_encoder at model.rgb_width x rgb_height) followed by one
// linear head per output on its flattened feature map, so what is learned
// sits in the CNN that VLN reuses. Loss per image: the binary
// cross-entropies of both multi-label heads summed over their labels plus
// the room cross-entropy, averaged over a batch; Adam(pretrain.lr), batches
// of pretrain.batch_size images.
//
// Held-out results (pretrain.eval_samples views in the held-out houses,
// after every epoch): room-type accuracy, and for categories and colours
// the mean average precision over the labels present in the held-out views
// and micro/macro F1 at probability 0.5. The reference is the prior
// predictor that ignores the image: the training label frequencies as
// scores (F1: a label is predicted when its frequency exceeds 0.5) and the
// most frequent room type.
//
// Reads: pretrain.*, trainer.seed, trainer.torch_threads, trainer.
// env_threads (rendering threads), trainer.grad_clip, trainer.
// max_nonfinite_updates, trainer.log_every_updates, sim.* (RGB camera,
// navmesh, renderer), model.rgb_* and output.tensorboard.

#include <cstdint>
#include <filesystem>
#include <memory>
#include <span>
#include <vector>

#include "models/SemanticNet.h"
#include "sim/Mesh.h"
#include "train/ExperimentConfig.h"
#include "world/ViewLabels.h"

namespace vln::train {

// the labels (world/ViewLabels.h), under the names the tests and the
// pretraining have always used
using world::labelView;
using world::ViewLabels;

/// Average precision of `scores` for the 0/1 `labels` of one label: the
/// mean, over the positives, of the precision at their score. Equal scores
/// form one threshold, so a constant score gives the prevalence. NaN when
/// there is no positive.
double averagePrecision(std::span<const float> scores,
                        std::span<const uint8_t> labels);

/// Multi-label results over a set of images.
struct MultiLabelMetrics {
  double mean_ap = 0.0;  ///< over the labels with a positive
  int labels_evaluated = 0;
  double micro_f1 = 0.0;  ///< at probability 0.5, all labels pooled
  double macro_f1 = 0.0;  ///< mean F1 over the labels with a positive
  std::vector<double> ap;  ///< per label (NaN without positives)
};

/// Multi-label metrics of `probabilities` [N, L] against `labels` [N, L]
/// (both row-major, 0/1 labels).
MultiLabelMetrics multiLabelMetrics(std::span<const float> probabilities,
                                    std::span<const uint8_t> labels,
                                    int64_t numLabels);

/// Held-out results of one predictor.
struct SemanticMetrics {
  int64_t images = 0;
  double room_accuracy = 0.0;
  MultiLabelMetrics categories;
  MultiLabelMetrics colors;
};

/// What a run produced.
struct SemanticResult {
  SemanticMetrics model;  ///< the trained network, after the last epoch
  SemanticMetrics prior;  ///< the label-prior predictor
  double initial_loss = 0.0;  ///< loss of the first batch, before training
  double final_loss = 0.0;    ///< mean loss of the last epoch
  int64_t train_images = 0;   ///< views rendered for training
  double seconds = 0.0;
  std::filesystem::path encoder_file;
};

/// Runs the whole task in `runDir` (metrics.jsonl, tb/,
/// pretrain_metrics.json, the encoder file, semantic_net.pt with the heads).
class SemanticPretrainer {
 public:
  /// Checks the config (validatePretrainConfig()) and generates the houses.
  SemanticPretrainer(const ExperimentConfig& config,
                     std::filesystem::path runDir);
  ~SemanticPretrainer();
  SemanticResult run();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace vln::train
