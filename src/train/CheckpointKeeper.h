#pragma once
// The checkpoints of a VLN training run (<output.dir>/checkpoints): writing
// them, keeping output.keep_checkpoints of them besides the best, the best
// one by eval.selection_split SPL (best.json; the paper's early stopping)
// and trainer.early_stopping_patience, and reading the one to resume from.
//
// In a multi-process run every rank keeps the same bookkeeping; only the
// one that `writes` (rank 0) touches files, and it sends the checkpoint to
// resume from to the others, whose run directories may be elsewhere.

#include <filesystem>
#include <optional>
#include <string>

#include "train/Checkpoint.h"
#include "train/ExperimentConfig.h"

namespace vln::train {

class Distributed;

class CheckpointKeeper {
 public:
  CheckpointKeeper(const ExperimentConfig& config, std::filesystem::path dir,
                   bool writes);

  /// With `resume`, the newest checkpoint of the directory (rank 0 reads
  /// it and broadcasts it over `dist`), and in `source` where it came from;
  /// nullopt for a fresh run or an empty directory. Restores the patience
  /// count it holds.
  std::optional<Checkpoint> resumeFrom(bool resume, Distributed* dist,
                                       std::string& source);

  /// Writes `checkpoint` as ckpt.<progress.checkpoint_index>.pth
  /// (atomically), then removes the oldest beyond output.keep_checkpoints,
  /// never the newest (--resume needs it) nor the best.
  void save(const Checkpoint& checkpoint);

  /// After checkpoint `index` scored `spl` on eval.selection_split: a
  /// better SPL than any before makes it the best (progress.best_spl,
  /// best_checkpoint, best.json) and resets the patience count. Returns
  /// true when early stopping is due.
  bool recordEvaluation(TrainingProgress& progress, int index, double spl);
  /// trainer.early_stopping_patience evaluations in a row brought no
  /// better SPL.
  bool patienceExhausted() const;
  /// Evaluations since the best one (saved in TrainingProgress::extra).
  int evalsSinceBest() const { return evalsSinceBest_; }

  const std::filesystem::path& dir() const { return dir_; }

 private:
  void prune(int best);

  ExperimentConfig config_;
  std::filesystem::path dir_;
  bool writes_;
  int evalsSinceBest_ = 0;
};

}  // namespace vln::train
