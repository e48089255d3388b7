#pragma once
// Teacher forcing by re-simulation (trainer.mode: recollect; VLN-CE's
// recollect_trainer, the starter trainer of its RxR-Habitat baselines): no
// feature store. Every epoch replays the training episodes' ground-truth
// action sequences (<split>_gt.json.gz) in the simulator (Recollection.h)
// and trains on the observations as they are rendered, so the disk holds
// no features however large the dataset.
//
// Episodes: the training pool (dataset.train_split, plus aug with
// trainer.use_aug, plus dataset.extra_train_splits) that has ground truth,
// minus the episodes with more than trainer.max_traj_len actions (left
// out, as VLN-CE does, not cut). Labels are the ground truth's actions
// (trainer.expert plays no part); trainer.dagger_iterations must be 0.
//
// An epoch: the episodes' batches in epochBatches() order (seeded by
// trainer.seed and the epoch, length-sorted chunks, as the store's teacher
// forcing), grouped into updates of effective_batch_size / batch_size
// batches (ImitationLearner::updateAccumulated(): exactly the update of the
// concatenated batches; one batch per update with effective_batch_size
// -1). Updates are simulated trainer.preload_size episodes ahead (at
// least one update's worth, whole updates) and held in memory, float32.
// A checkpoint after every epoch, then (trainer.eval_during_training) an
// evaluation through PeriodicEvaluator, early stopping and best.json as
// VlnTrainer.h.
//
// Where it differs from VLN-CE (docs/paper_scale.md):
//  - VLN-CE steps its environments through the dataset in order and
//    batches episodes as they finish (its own comment: length not
//    considered); here batches are drawn per epoch by seed, so a run's
//    batches do not depend on its environments;
//  - VLN-CE's accumulation divides each batch's loss by the number of
//    batches and steps when step_id % k is non-zero (for k > 2 that steps
//    more often than every k batches); here each update is exactly k
//    batches (fewer for an epoch's last), weighted by their episodes and
//    steps;
//  - VLN-CE drops an epoch's last partial batch; here it is trained on.
//
// --resume: from the last checkpoint's epoch with its policy, Adam state
// and RNG states; the next epoch's episodes, batches and features are
// those of an uninterrupted run, bit for bit while trainer.num_envs is
// unchanged (the features are batched over the environments). An epoch
// interrupted midway is redone from its start. A checkpoint of another
// trainer mode is refused. One process only: WORLD_SIZE > 1 is refused.

#include <memory>

#include "train/ExperimentConfig.h"

namespace vln::train {

class RecollectTrainer {
 public:
  /// Loads the data (the pool with ground truth, Recollection.h), the
  /// embeddings, the policy and the encoders; with `resume`, restores the
  /// last checkpoint of output.dir. Throws std::invalid_argument for an
  /// unusable pool (recollectionPool()), for a checkpoint written by
  /// trainer.mode dagger, and for model.instruction_features rxr_text
  /// (not wired yet: the text features of RxR episodes reach the batches
  /// with RxR dataset reading).
  RecollectTrainer(const ExperimentConfig& config, bool resume);
  ~RecollectTrainer();

  /// Trains until trainer.epochs or early stopping.
  void run();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace vln::train
