#include "train/CheckpointKeeper.h"

#include <spdlog/spdlog.h>

#include <algorithm>

#include "common/Json.h"
#include "train/Distributed.h"

namespace vln::train {
namespace fs = std::filesystem;

CheckpointKeeper::CheckpointKeeper(const ExperimentConfig& config, fs::path dir,
                                   bool writes)
    : config_(config), dir_(std::move(dir)), writes_(writes) {}

std::optional<Checkpoint> CheckpointKeeper::resumeFrom(bool resume,
                                                       Distributed* dist,
                                                       std::string& source) {
  std::optional<Checkpoint> checkpoint;
  if (writes_ && resume) {
    const auto checkpoints = listCheckpoints(dir_);
    if (!checkpoints.empty()) {
      source = checkpoints.back().string();
      checkpoint = loadCheckpoint(checkpoints.back());
    }
  }
  if (dist) {
    const std::string bytes = dist->broadcastBytes(
        checkpoint ? serializeCheckpoint(*checkpoint) : std::string());
    if (!writes_ && !bytes.empty()) {
      source = "rank 0's checkpoint";
      checkpoint = deserializeCheckpoint(bytes, source);
    }
  }
  if (checkpoint)
    evalsSinceBest_ = checkpoint->progress.extra.value("evals_since_best", 0);
  return checkpoint;
}

void CheckpointKeeper::save(const Checkpoint& checkpoint) {
  if (!writes_) return;
  const int index = checkpoint.progress.checkpoint_index;
  const fs::path file = dir_ / checkpointFileName(index);
  saveCheckpoint(file, checkpoint);
  spdlog::info("saved {} ({} updates)", file.string(),
               checkpoint.progress.updates);
  prune(checkpoint.progress.best_checkpoint);
}

void CheckpointKeeper::prune(int best) {
  const int keep = config_.output.keep_checkpoints;
  if (keep < 0) return;
  const auto all = listCheckpoints(dir_);
  // the newest is needed to resume
  const auto kept = static_cast<size_t>(std::max(keep, 1));
  for (size_t i = 0; i + kept < all.size(); ++i) {
    if (checkpointIndex(all[i]) == best) continue;
    std::error_code ec;
    fs::remove(all[i], ec);
    if (!ec)
      spdlog::info("removed {} (output.keep_checkpoints = {})", all[i].string(),
                   keep);
  }
}

bool CheckpointKeeper::recordEvaluation(TrainingProgress& progress, int index,
                                        double spl) {
  const std::string& split = config_.eval.selection_split;
  if (spl > progress.best_spl) {
    progress.best_spl = spl;
    progress.best_checkpoint = index;
    evalsSinceBest_ = 0;
    if (writes_)
      common::writeJsonFile(dir_ / "best.json",
                            {{"checkpoint", checkpointFileName(index)},
                             {"index", index},
                             {"split", split},
                             {"spl", spl}},
                            2);
    spdlog::info("new best checkpoint {}: {} SPL {:.4f}", index, split, spl);
  } else {
    ++evalsSinceBest_;
  }
  if (!patienceExhausted()) return false;
  spdlog::info(
      "early stopping: {} evaluations without a better {} SPL than {:.4f} "
      "(ckpt {})",
      evalsSinceBest_, split, progress.best_spl, progress.best_checkpoint);
  return true;
}

bool CheckpointKeeper::patienceExhausted() const {
  const int patience = config_.trainer.early_stopping_patience;
  return patience > 0 && evalsSinceBest_ >= patience;
}

}  // namespace vln::train
