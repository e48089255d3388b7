// CheckpointKeeper: which checkpoints survive pruning, the best one and its
// best.json, early stopping by patience, and resuming from the newest.

#include "train/CheckpointKeeper.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <torch/torch.h>

#include "common/Json.h"
#include "support/TestPaths.h"

namespace vln::train {
namespace {

namespace fs = std::filesystem;
using ::testing::ElementsAre;

ExperimentConfig keeperConfig(int keep, int patience) {
  ExperimentConfig c;
  c.output.keep_checkpoints = keep;
  c.trainer.early_stopping_patience = patience;
  c.eval.selection_split = "val_unseen";
  return c;
}

Checkpoint checkpointAt(const TrainingProgress& progress) {
  Checkpoint c;
  c.policy = {
      {"w", torch::full({2}, static_cast<float>(progress.checkpoint_index))}};
  c.progress = progress;
  return c;
}

std::vector<int> indices(const fs::path& dir) {
  std::vector<int> out;
  for (const auto& file : listCheckpoints(dir))
    out.push_back(*checkpointIndex(file));
  return out;
}

TEST(CheckpointKeeperTest, KeepsTheNewestAndTheBest) {
  vln::test::TempDir dir;
  const fs::path checkpoints = dir.path() / "checkpoints";
  CheckpointKeeper keeper(keeperConfig(/*keep=*/2, /*patience=*/0), checkpoints,
                          true);
  TrainingProgress progress;
  const double spl[] = {0.1, 0.4, 0.2, 0.3, 0.35};
  for (int i = 0; i < 5; ++i) {
    progress.checkpoint_index = i;
    keeper.save(checkpointAt(progress));
    EXPECT_FALSE(keeper.recordEvaluation(progress, i, spl[i]));
  }
  // the best (1) survives pruning, besides the two newest
  EXPECT_THAT(indices(checkpoints), ElementsAre(1, 3, 4));
  EXPECT_EQ(progress.best_checkpoint, 1);
  EXPECT_DOUBLE_EQ(progress.best_spl, 0.4);
  const auto best = common::readJsonFile(checkpoints / "best.json");
  EXPECT_EQ(best["checkpoint"], "ckpt.1.pth");
  EXPECT_EQ(best["index"], 1);
  EXPECT_EQ(best["split"], "val_unseen");
  EXPECT_DOUBLE_EQ(best["spl"].get<double>(), 0.4);
  // what a DA* config's init_checkpoint and train --export pick
  EXPECT_EQ(bestOrLatestCheckpoint(dir.path()), checkpoints / "ckpt.1.pth");
  fs::remove(checkpoints / "best.json");
  EXPECT_EQ(bestOrLatestCheckpoint(dir.path()), checkpoints / "ckpt.4.pth");
}

TEST(CheckpointKeeperTest, KeepingOneStillKeepsTheNewest) {
  vln::test::TempDir dir;
  CheckpointKeeper keeper(keeperConfig(/*keep=*/0, 0), dir.path(), true);
  TrainingProgress progress;
  for (int i = 0; i < 3; ++i) {
    progress.checkpoint_index = i;
    keeper.save(checkpointAt(progress));
  }
  EXPECT_THAT(indices(dir.path()), ElementsAre(2));
}

TEST(CheckpointKeeperTest, StopsAfterPatienceEvaluationsWithoutABetterSpl) {
  vln::test::TempDir dir;
  CheckpointKeeper keeper(keeperConfig(-1, /*patience=*/2), dir.path(), true);
  TrainingProgress progress;
  EXPECT_FALSE(keeper.recordEvaluation(progress, 0, 0.2));
  EXPECT_FALSE(keeper.recordEvaluation(progress, 1, 0.2));  // not better
  EXPECT_FALSE(keeper.recordEvaluation(progress, 2, 0.3));  // better: reset
  EXPECT_EQ(keeper.evalsSinceBest(), 0);
  EXPECT_FALSE(keeper.recordEvaluation(progress, 3, 0.1));
  EXPECT_FALSE(keeper.patienceExhausted());
  EXPECT_TRUE(keeper.recordEvaluation(progress, 4, 0.25));
  EXPECT_TRUE(keeper.patienceExhausted());
  EXPECT_EQ(progress.best_checkpoint, 2);
}

TEST(CheckpointKeeperTest, AProcessThatDoesNotWriteKeepsTheSameBookkeeping) {
  vln::test::TempDir dir;
  CheckpointKeeper keeper(keeperConfig(-1, 1), dir.path(), /*writes=*/false);
  TrainingProgress progress;
  progress.checkpoint_index = 0;
  keeper.save(checkpointAt(progress));
  EXPECT_FALSE(keeper.recordEvaluation(progress, 0, 0.5));
  EXPECT_TRUE(keeper.recordEvaluation(progress, 1, 0.5));
  EXPECT_EQ(progress.best_checkpoint, 0);
  EXPECT_TRUE(listCheckpoints(dir.path()).empty());
  EXPECT_FALSE(fs::exists(dir.path() / "best.json"));
}

TEST(CheckpointKeeperTest, ResumesFromTheNewestWithItsPatienceCount) {
  vln::test::TempDir dir;
  CheckpointKeeper first(keeperConfig(-1, 3), dir.path(), true);
  TrainingProgress progress;
  for (int i = 0; i < 3; ++i) {
    progress.checkpoint_index = i;
    progress.extra["evals_since_best"] = i;
    first.save(checkpointAt(progress));
  }
  CheckpointKeeper again(keeperConfig(-1, 3), dir.path(), true);
  std::string source;
  EXPECT_FALSE(again.resumeFrom(/*resume=*/false, nullptr, source).has_value());
  const std::optional<Checkpoint> last =
      again.resumeFrom(true, nullptr, source);
  ASSERT_TRUE(last.has_value());
  EXPECT_EQ(last->progress.checkpoint_index, 2);
  EXPECT_EQ(fs::path(source).filename(), "ckpt.2.pth");
  EXPECT_EQ(again.evalsSinceBest(), 2);
  // one more evaluation without a better SPL exhausts the patience of 3
  TrainingProgress resumed = last->progress;
  resumed.best_spl = 0.5;
  EXPECT_TRUE(again.recordEvaluation(resumed, 3, 0.4));
}

}  // namespace
}  // namespace vln::train
