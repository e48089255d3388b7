// End-to-end runs of the `train` binary in trainer.mode recollect
// (src/train/RecollectTrainer.cpp) on the tiny procedural world: a run
// with gradient accumulation trains, checkpoints, evaluates and writes no
// feature store; a run resumed after its first epoch ends with the weights
// of an uninterrupted one, bit for bit; and it trains what the store's
// teacher forcing trains with the reference-path expert (whose actions
// are the ground truth's).

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <map>

#include "TinyWorldBinaryTest.h"
#include "TrainTestWorld.h"
#include "common/Json.h"
#include "data/Episode.h"
#include "data/Split.h"
#include "rollout/Metrics.h"
#include "support/TestUtil.h"
#include "train/Checkpoint.h"

namespace vln::train {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using vln::test::binary;
using vln::test::readJsonLines;

class RecollectTrainerTest : public test::TinyWorldBinaryTest {
 protected:
  RecollectTrainerTest() : TinyWorldBinaryTest("train") {}

  fs::path writeConfig(const std::string& name, const std::string& trainer) {
    return vln::test::writeText(
        dir_ / (name + ".yaml"),
        test::tinyRunConfig(*world_, dir_ / name,
                            "  mode: recollect\n" + trainer));
  }

  int train(const fs::path& config, const std::string& extra,
            std::string* output) {
    return vln::test::runCommand(binary("train") + " --config " +
                                     config.string() + " " + extra + " 2>&1",
                                 output);
  }
};

TEST_F(RecollectTrainerTest, AccumulatingRunTrainsCheckpointsAndEvaluates) {
  // batch_size 3 (tinyRunConfig), two batches per update, one update
  // simulated ahead
  const fs::path config = writeConfig(
      "run", "  epochs: 1\n  effective_batch_size: 6\n  preload_size: 3\n");
  std::string output;
  ASSERT_EQ(train(config, "", &output), 0) << output;
  const fs::path run = dir_ / "run";
  EXPECT_FALSE(fs::exists(run / "store")) << "recollect stores no features";

  const size_t episodes =
      data::readEpisodes(data::splitEpisodesPath(world_->data, "train"))
          .episodes.size();
  const int64_t batches = (static_cast<int64_t>(episodes) + 2) / 3;
  const auto checkpoints = listCheckpoints(run / "checkpoints");
  ASSERT_EQ(checkpoints.size(), 1u);
  const Checkpoint ckpt = loadCheckpoint(checkpoints.back());
  EXPECT_EQ(ckpt.progress.stage, "recollect");
  EXPECT_EQ(ckpt.progress.epoch, 1);
  EXPECT_EQ(ckpt.progress.updates, (batches + 1) / 2);

  std::map<std::string, int> types;
  for (const auto& record : readJsonLines(run / "metrics.jsonl")) {
    const std::string type = record["type"].get<std::string>();
    ++types[type];
    if (type == "recollect") {
      // every train episode replayed once, where its ground truth went
      EXPECT_EQ(record["episodes"].get<int64_t>(),
                static_cast<int64_t>(episodes));
      EXPECT_EQ(record["off_ground_truth"].get<int64_t>(), 0);
      EXPECT_EQ(record["batches_per_update"].get<int>(), 2);
    }
    if (type == "update") {
      EXPECT_TRUE(std::isfinite(record["loss"].get<double>()));
      EXPECT_GT(record["steps"].get<int64_t>(), 0);
    }
    if (type == "epoch") {
      EXPECT_EQ(record["updates"].get<int64_t>(), (batches + 1) / 2);
    }
  }
  EXPECT_EQ(types["recollect"], 1);
  EXPECT_EQ(types["epoch"], 1);
  EXPECT_EQ(types["eval"], 2);  // val_seen and val_unseen after the epoch
  for (const char* split : {"val_seen", "val_unseen"})
    EXPECT_EQ(
        rollout::readStatsFile(run / "eval" / rollout::statsFileName(0, split))
            .num_episodes,
        2);
  const auto finished = common::readJsonFile(run / "finished.json");
  EXPECT_EQ(finished["reason"], "completed");
  EXPECT_EQ(finished["mode"], "recollect");
  EXPECT_TRUE(fs::exists(run / "checkpoints" / "best.json"));

  // a finished run resumes to nothing new; another mode is refused
  ASSERT_EQ(train(config, "--resume", &output), 0) << output;
  EXPECT_EQ(listCheckpoints(run / "checkpoints").size(), 1u);
  EXPECT_NE(train(config, "--resume --set trainer.mode=dagger", &output), 0);
  EXPECT_THAT(output, HasSubstr("trainer.mode"));
}

TEST_F(RecollectTrainerTest, ResumedRunEndsWithTheWeightsOfAnUninterruptedOne) {
  const std::string trainer =
      "  eval_during_training: false\n  effective_batch_size: 6\n";
  std::string output;
  const fs::path straight = writeConfig("straight", "  epochs: 2\n" + trainer);
  ASSERT_EQ(train(straight, "", &output), 0) << output;
  const fs::path halves = writeConfig("halves", "  epochs: 1\n" + trainer);
  ASSERT_EQ(train(halves, "", &output), 0) << output;
  ASSERT_EQ(train(halves, "--resume --set trainer.epochs=2", &output), 0)
      << output;
  EXPECT_THAT(output, HasSubstr("train --resume: trainer.epochs changed"));

  const Checkpoint a =
      loadCheckpoint(listCheckpoints(dir_ / "straight" / "checkpoints").back());
  const Checkpoint b =
      loadCheckpoint(listCheckpoints(dir_ / "halves" / "checkpoints").back());
  EXPECT_EQ(a.progress.epoch, 2);
  EXPECT_EQ(b.progress.epoch, 2);
  EXPECT_EQ(a.progress.updates, b.progress.updates);
  ASSERT_EQ(a.policy.size(), b.policy.size());
  for (size_t i = 0; i < a.policy.size(); ++i)
    EXPECT_TRUE(torch::equal(a.policy[i].second, b.policy[i].second))
        << a.policy[i].first;
  EXPECT_EQ(a.optimizer_state, b.optimizer_state);
}

// The store's teacher forcing with trainer.expert reference_path labels
// every episode with its ground-truth actions and, its round being the
// pool in order, draws the same batches; with float32 features both runs
// make the same updates up to the rounding of batched encoding.
TEST_F(RecollectTrainerTest, TrainsWhatTheStoresTeacherForcingTrains) {
  const std::string common = "  epochs: 1\n  eval_during_training: false\n";
  // every update in the metrics
  const std::string everyUpdate = "--set trainer.log_every_updates=1";
  std::string output;
  const fs::path recollect = writeConfig("recollect", common);
  ASSERT_EQ(train(recollect, everyUpdate, &output), 0) << output;
  const fs::path stored = vln::test::writeText(
      dir_ / "stored.yaml",
      test::tinyRunConfig(*world_, dir_ / "stored",
                          common + "  expert: reference_path\n"
                                   "  store_fp16: false\n"));
  ASSERT_EQ(train(stored, everyUpdate, &output), 0) << output;

  auto losses = [](const fs::path& run) {
    std::vector<double> out;
    for (const auto& record : readJsonLines(run / "metrics.jsonl"))
      if (record["type"] == "update")
        out.push_back(record["loss"].get<double>());
    return out;
  };
  const std::vector<double> a = losses(dir_ / "recollect");
  const std::vector<double> b = losses(dir_ / "stored");
  ASSERT_EQ(a.size(), b.size());
  ASSERT_GT(a.size(), 2u);
  for (size_t i = 0; i < a.size(); ++i)
    EXPECT_NEAR(a[i], b[i], 1e-4 * std::abs(b[i])) << "update " << i + 1;
  const Checkpoint x = loadCheckpoint(
      listCheckpoints(dir_ / "recollect" / "checkpoints").back());
  const Checkpoint y =
      loadCheckpoint(listCheckpoints(dir_ / "stored" / "checkpoints").back());
  ASSERT_EQ(x.policy.size(), y.policy.size());
  for (size_t i = 0; i < x.policy.size(); ++i)
    EXPECT_TRUE(torch::allclose(x.policy[i].second, y.policy[i].second,
                                /*rtol=*/1e-3, /*atol=*/1e-5))
        << x.policy[i].first;
}

}  // namespace
}  // namespace vln::train
