#pragma once
// Imitation learning of the VLN policy (trainer.task = vln; paper
// Sections 4.3 and 5), teacher forcing or DAgger, in a run directory (see
// RunDirectory.h for its layout).
//
// Teacher forcing (trainer.dagger_iterations == 0): round 0 collects every
// training episode once with the oracle (beta = 1), plus every episode of
// dataset.aug_split when trainer.use_aug (both stored; batches are drawn
// from their union), then trains trainer.epochs epochs over the store; a
// checkpoint after every epoch, then (trainer.eval_during_training) an
// evaluation.
//
// DAgger: iteration n collects trainer.dagger_episodes episodes with
// beta = dagger_beta^n (n + 1 when fine_tune_dagger; beta = 0 when
// dagger_beta = 0, as VLN-CE), appends them to the aggregated store and
// trains trainer.dagger_epochs epochs over everything collected so far; a
// checkpoint after every epoch, an evaluation after every iteration. Round
// n's episodes are the training pool (train split, plus aug split when
// use_aug) shuffled by (seed, n) and repeated to dagger_episodes; with
// beta = 1 each episode once at most (VLN-CE collects unique episodes then).
//
// Checkpoints: checkpoints/ckpt.<i>.pth, i increasing over the whole run;
// TrainingProgress holds the completed DAgger iterations and epochs of the
// current stage, so --resume knows where it is:
//  - collection of the current round resumes from the store: slots already
//    stored are skipped (Collector.h), so an interruption during collection
//    loses only the episodes in flight;
//  - training resumes after the last checkpoint's epoch with its policy,
//    Adam state and RNG states (an interrupted epoch is redone from its
//    start, in the same batch order);
//  - an evaluation due after the last checkpoint and missing from eval/
//    is run first.
// Early stopping: after trainer.early_stopping_patience evaluations without
// a better eval.selection_split SPL, training stops. checkpoints/best.json
// names the best checkpoint; output.keep_checkpoints newest checkpoints are
// kept besides the best (the newest always, --resume needs it).
//
// Multi-process (docs/distributed.md, DistributedTraining.h): rank r
// collects the slots k of every round with k % WORLD_SIZE == r into its own
// store shard (store/rank<r>/) and trains on it; every update combines the
// gradients of all ranks into that of the union of their batches
// (ImitationLearner::setDistributed()), so the ranks' policies stay bitwise
// identical (checked after every epoch). Rank 0 reads
// the checkpoint to resume from and sends it to the others; at a fresh start
// every rank takes rank 0's initial weights. Rank 0 alone writes
// checkpoints, metrics, TensorBoard events, eval stats, best.json and
// finished.json. Evaluations are sharded: rank r runs episodes r, r + N, ...
// of each split and the metric sums are all-reduced, so rank 0's stats cover
// the whole split.

#include <filesystem>
#include <memory>
#include <string>

#include "train/ExperimentConfig.h"

namespace vln::train {

class Distributed;

class VlnTrainer {
 public:
  /// Loads the data, the embeddings, the policy and the encoders; with
  /// `resume`, restores the last checkpoint of output.dir. `dist` (which
  /// must outlive the trainer) makes this one rank of a multi-process run;
  /// nullptr trains in this process alone. Throws std::invalid_argument
  /// when WORLD_SIZE exceeds the episodes of a collection round.
  VlnTrainer(const ExperimentConfig& config, bool resume,
             Distributed* dist = nullptr);
  ~VlnTrainer();

  /// Trains until the configured end or early stopping.
  void run();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace vln::train
