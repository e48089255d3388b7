#pragma once
// What the VLN trainer does and in which order (paper Sections 4.3 and 5),
// as a pure function of trainer.*: no simulator, no model, no files.
//
// Teacher forcing (trainer.dagger_iterations == 0) is one round: every
// episode of the training pool (train split, plus the aug split with
// trainer.use_aug) once, driven by the oracle (beta = 1), then
// trainer.epochs epochs, each followed by a checkpoint and (with
// trainer.eval_during_training) an evaluation.
//
// DAgger: iteration n collects trainer.dagger_episodes episodes with
// beta = dagger_beta^n (n + 1 with fine_tune_dagger; 0 when dagger_beta is
// 0, as VLN-CE) into the aggregated store, then trains trainer.dagger_epochs
// epochs over everything collected so far, a checkpoint after each and an
// evaluation after each (trainer.evaluate_every: epoch, VLN-CE) or after
// the iteration's last (iteration). Round n's episodes are the pool
// shuffled by (seed, n) and repeated up to dagger_episodes; with beta = 1
// each episode at most once (VLN-CE collects unique episodes then).
//
// Where a run stands is the pair (completed iterations, completed epochs
// of the current iteration) that checkpoints store as
// TrainingProgress::dagger_iteration and ::epoch; teacher forcing keeps
// the iteration at 0 and counts its epochs.

#include <cstddef>
#include <string>
#include <vector>

#include "train/ExperimentConfig.h"

namespace vln::train {

/// One epoch of training and what follows it.
struct ScheduledEpoch {
  int epoch = 0;  ///< within its iteration
  /// An evaluation follows this epoch's checkpoint.
  bool evaluate_after = false;
  /// TrainingProgress::dagger_iteration and ::epoch once it is done.
  int iterations_done = 0;
  int epochs_done = 0;
};

/// One iteration: its round's collection (unless a resumed run is past it)
/// and its epochs still to train.
struct ScheduledIteration {
  int iteration = 0;  ///< DAgger iteration (0 for teacher forcing)
  bool collect = false;
  std::vector<ScheduledEpoch> epochs;
};

/// `rate` at epoch `epoch` of a round of `epochs` epochs: itself with
/// `schedule` "constant"; with "cosine", times (1 + cos(pi epoch / epochs))
/// / 2, so the round's last epochs take small steps. Shared by the VLN
/// trainers (trainer.lr_schedule) and the pretrainers (pretrain.lr_schedule).
double roundLearningRate(double rate, const std::string& schedule, int epoch,
                         int epochs);

class TrainingSchedule {
 public:
  explicit TrainingSchedule(const TrainerConfig& trainer);

  bool dagger() const { return trainer_.dagger_iterations > 0; }
  /// Collection rounds: dagger_iterations, or 1 for teacher forcing.
  int iterations() const;
  /// Epochs after each round: dagger_epochs, or epochs.
  int epochsPerIteration() const;
  /// The probability that round `iteration` takes the oracle's action.
  double beta(int iteration) const;
  /// The learning rate of epoch `epoch` (within its iteration) of
  /// iteration `iteration`: trainer.lr * trainer.lr_decay^iteration, times
  /// (1 + cos(pi epoch / epochsPerIteration())) / 2 with
  /// trainer.lr_schedule "cosine". A function of the two indices alone, so
  /// a resumed run trains at the rates of an uninterrupted one.
  double learningRate(int iteration, int epoch) const;

  /// The episodes of round `iteration` as indices into a pool of
  /// `poolSize` episodes, slot by slot (see the file comment).
  std::vector<size_t> roundEpisodes(int iteration, size_t poolSize) const;
  /// The fewest episodes of any round for a pool of `poolSize`.
  size_t smallestRound(size_t poolSize) const;

  /// What is still to do after `iterationsDone` completed iterations and
  /// `epochsDone` completed epochs of the next, in order. A round is
  /// collected before its first epoch (resuming a round whose collection
  /// was interrupted collects its missing episodes).
  std::vector<ScheduledIteration> remaining(int iterationsDone,
                                            int epochsDone) const;

 private:
  TrainerConfig trainer_;
};

}  // namespace vln::train
