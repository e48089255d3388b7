#pragma once
// Training the candidate-waypoint predictor (trainer.task =
// waypoint_predictor; issue 18, docs/waypoints.md), as Hong et al. (CVPR
// 2022) train theirs on Matterport3D's connectivity:
//
//  - Data: the transferred nav-graph nodes (data::transferGraph()) of the
//    houses of waypoint.train_split; on each, waypoint.headings_per_node
//    random headings (from trainer.seed), each one panorama (`panorama:`
//    section, the model's image sizes) with its targets from
//    waypoint::nodeTargets() (nodes whose targets all lie behind obstacles
//    are dropped, as theirs). The evaluation panoramas are the nodes of
//    waypoint.eval_split's houses with one heading each, drawn from
//    waypoint.eval_seed exactly as `vlnce-data waypoint-metrics --seed`
//    draws them, so both see the same agents.
//  - Encoders: the project's frozen depth and RGB CNNs (model.*_encoder,
//    model.depth_weights / rgb_weights, model.no_rgb / no_depth), run once
//    per panorama: the features are cached in memory and every epoch
//    reuses them (the encoders cannot be trained by this task).
//  - Network: models::WaypointPredictor (`waypoint.predictor:`); loss
//    waypoint.loss (Hong et al.'s squared error of the logits against the
//    target of peak waypoint.target_scale, or a softmax cross-entropy);
//    AdamW, batches of waypoint.batch_size panoramas, waypoint.epochs
//    passes in an order from trainer.seed.
//  - Evaluation after every epoch: softmax over the 1440 cells,
//    waypoint::heatmapNms() (waypoint.nms_*), waypoint::scoreCandidates()
//    into PredictorMetrics: the code and metrics of the depth-only
//    baseline, which is scored on the same panoramas beside it with the
//    targets' own cells (the quantisation floor).
//
// Writes in the run directory metrics.jsonl (and tb/ with
// output.tensorboard), pretrain_metrics.json (every epoch's evaluation,
// the last one as "model", the baseline and the floor) and the weights
// (waypoint.weights_out, default <runDir>/waypoint_predictor.pt, a tensor
// file models::loadModule() reads into a WaypointPredictor built from the
// same config). Like the other pretraining tasks a run is minutes long and
// keeps no resumable state (train --resume is refused).
//
// Determinism: with the same trainer.torch_threads a run is repeatable
// (houses render on trainer.env_threads threads, each into its own slot).

#include <torch/torch.h>

#include <filesystem>
#include <memory>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "train/ExperimentConfig.h"
#include "waypoint/WaypointMetrics.h"

namespace vln::train {

/// Checks what the YAML bounds cannot: the panorama (sim::
/// checkPanoramaConfig()), its image sizes equal to the model's, frozen
/// encoders, 120 divisible by the views, the predictor's heads. Throws
/// std::invalid_argument naming the key.
void validateWaypointPretrainConfig(const ExperimentConfig& config);

/// The panorama checks of validateWaypointPretrainConfig(), shared with the
/// waypoint agent's; errors begin with `task`.
void checkWaypointPanorama(const ExperimentConfig& config,
                           std::string_view task);

/// Scores heatmap logits [N, 120, 12] of N panoramas against their
/// targets (targets[i] for row i): softmax over the cells, heatmapNms()
/// with the config's settings, scoreCandidates().
waypoint::PredictorMetrics scoreWaypointLogits(
    const torch::Tensor& logits,
    const std::vector<waypoint::NodeTargets>& targets,
    const WaypointPretrainConfig& config);

/// What a run produced.
struct WaypointPretrainResult {
  waypoint::PredictorMetrics model;     ///< after the last epoch
  waypoint::PredictorMetrics baseline;  ///< depth-only, same panoramas
  waypoint::PredictorMetrics floor;     ///< the targets' own cells
  double initial_loss = 0.0;            ///< first batch, before any update
  double final_loss = 0.0;  ///< mean training loss of the last epoch
  int64_t train_panoramas = 0;
  int64_t eval_panoramas = 0;
  double seconds = 0.0;
  std::filesystem::path weights_file;
};

class WaypointPretrainer {
 public:
  /// Checks the config (validateWaypointPretrainConfig()).
  WaypointPretrainer(const ExperimentConfig& config,
                     std::filesystem::path runDir);
  ~WaypointPretrainer();
  WaypointPretrainResult run();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// trainer.task = waypoint_predictor: WaypointPretrainer(config,
/// runDir).run(). Expects logging set up.
void runWaypointPredictorPretraining(const ExperimentConfig& config,
                                     const std::filesystem::path& runDir);

}  // namespace vln::train
