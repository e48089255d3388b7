// RxR-CE end to end through the `train` and `eval` binaries: the RxR split
// of configs/world/tiny.yaml's houses (RxR_VLNCE_v0 layout, guide and
// follower roles), text features written in RxR's .npz layout, a CMA with
// model.instruction_features: rxr_text and six actions trained by teacher
// forcing then one DAgger round (the policy reads the features while
// collecting), validated during training, then scored by `eval`, which
// writes the RxR inference .jsonl. A missing feature file stops the run
// with the file and the episode named.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>

#include "RxrTrainTestWorld.h"
#include "TinyWorldBinaryTest.h"
#include "common/Json.h"
#include "data/RxrEpisodes.h"
#include "data/RxrPredictions.h"
#include "rollout/Metrics.h"
#include "support/TestPaths.h"
#include "support/TestUtil.h"
#include "train/Checkpoint.h"

namespace vln::train {
namespace {

namespace fs = std::filesystem;
using test::rxrRunConfig;
using test::TinyRxrWorld;
using test::tinyRxrWorld;
using ::testing::HasSubstr;
using vln::test::binary;

// A private copy of the world's feature files, for the tests that take one
// away: the world's own files are shared by tests running in parallel.
fs::path privateFeatures(const TinyRxrWorld& w, const fs::path& dir) {
  const fs::path copy = dir / "text_features";
  fs::create_directories(dir);
  fs::copy(w.data / "text_features", copy, fs::copy_options::recursive);
  return copy;
}

class RxrTrainEndToEndTest : public test::TinyWorldBinaryTest {
 protected:
  RxrTrainEndToEndTest() : TinyWorldBinaryTest("train") {}
};

TEST_F(RxrTrainEndToEndTest, TrainsAndEvaluatesOnTextFeaturesAndWritesJsonl) {
  if (!fs::exists(binary("eval"))) GTEST_SKIP() << "build eval first";
  const TinyRxrWorld& w = tinyRxrWorld();
  const fs::path run = dir_ / "run";
  const fs::path config =
      vln::test::writeText(dir_ / "rxr.yaml", rxrRunConfig(w, run));
  std::string output;
  ASSERT_EQ(
      vln::test::runCommand(
          binary("train") + " --config " + config.string() + " 2>&1", &output),
      0)
      << output;

  // two rounds collected (teacher forcing, then the policy acting), one
  // epoch each, validated after each iteration with the .jsonl beside
  // the stats
  int collected = 0;
  double oracleShare = 1.0;
  for (const auto& record : vln::test::readJsonLines(run / "metrics.jsonl"))
    if (record["type"] == "collect") {
      ++collected;
      oracleShare =
          record["oracle_steps"].get<double>() / record["steps"].get<double>();
    }
  EXPECT_EQ(collected, 2);
  EXPECT_LT(oracleShare, 1.0);  // the policy drove some steps
  const auto checkpoints = listCheckpoints(run / "checkpoints");
  ASSERT_EQ(checkpoints.size(), 2u);
  const auto duringTraining = data::readRxrPredictions(
      run / "eval" / "rxr_predictions_ckpt_1_val_unseen.jsonl");
  EXPECT_EQ(duringTraining.size(), 2u);  // eval.train_eval_episodes

  // the eval binary on every val_unseen guide episode
  data::RxrFilterConfig guide;
  const auto episodes = data::readRxrEpisodes(w.data, "val_unseen", guide);
  ASSERT_GE(episodes.size(), 2u);
  const fs::path out = dir_ / "eval";
  const std::string eval = binary("eval") + " --config " + config.string() +
                           " --checkpoint " + checkpoints.back().string() +
                           " --split val_unseen --out " + out.string() +
                           " 2>&1";
  ASSERT_EQ(vln::test::runCommand(eval, &output), 0) << output;
  const auto lines =
      data::readRxrPredictions(out / "rxr_predictions_ckpt_1_val_unseen.jsonl");
  ASSERT_EQ(lines.size(), episodes.size());
  std::set<int64_t> ids;
  for (const data::Episode& e : episodes)
    ids.insert(*e.instruction.instruction_id);
  for (const data::RxrPrediction& line : lines) {
    EXPECT_TRUE(ids.count(line.instruction_id)) << line.instruction_id;
    ASSERT_FALSE(line.path.empty());
  }
  // every path starts where its episode starts
  for (const data::Episode& e : episodes) {
    const auto it =
        std::find_if(lines.begin(), lines.end(), [&](const auto& l) {
          return l.instruction_id == *e.instruction.instruction_id;
        });
    ASSERT_NE(it, lines.end());
    EXPECT_LT((it->path.front() - e.start_position).norm(), 1e-4f);
  }
  const rollout::SplitStats stats =
      rollout::readStatsFile(out / rollout::statsFileName(1, "val_unseen"));
  EXPECT_EQ(stats.num_episodes, static_cast<int>(episodes.size()));
  EXPECT_TRUE(std::isfinite(stats.mean.ndtw));
  EXPECT_GE(stats.mean.ndtw, 0.0);
  EXPECT_TRUE(std::isfinite(stats.mean.sdtw));

  // a missing feature file is named with its episode before anything runs
  const data::Episode& first = episodes.front();
  const fs::path features = privateFeatures(w, dir_ / "private");
  const fs::path missing = data::rxrTextFeaturesPath(
      features, "val_unseen", *first.instruction.instruction_id,
      first.instruction.language);
  fs::remove(missing);
  const int code = vln::test::runCommand(
      binary("eval") + " --config " + config.string() +
          " --set dataset.text_features_dir=" + features.string() +
          " --checkpoint " + checkpoints.back().string() +
          " --split val_unseen --out " + (dir_ / "eval_missing").string() +
          " 2>&1",
      &output);
  EXPECT_NE(code, 0);
  EXPECT_THAT(output, HasSubstr(missing.filename().string()));
  EXPECT_THAT(output,
              HasSubstr("(episode " + std::to_string(first.episode_id)));
}

// VLN-CE's way to train on RxR: the recollect trainer replays the guide
// ground truth on the task itself (sliding off, as the RxR follower made
// it) with the text features in every batch; a missing file stops it
// before the first replay.
TEST_F(RxrTrainEndToEndTest, RecollectTrainsOnTextFeaturesWithoutSliding) {
  const TinyRxrWorld& w = tinyRxrWorld();
  const fs::path run = dir_ / "recollect";
  const fs::path config = vln::test::writeText(
      dir_ / "rxr_recollect.yaml", rxrRunConfig(w, run,
                                                "  mode: recollect\n"
                                                "  dagger_iterations: 0\n"
                                                "  epochs: 2\n"
                                                "  effective_batch_size: 6\n"
                                                "  preload_size: 6\n"));
  std::string output;
  ASSERT_EQ(
      vln::test::runCommand(
          binary("train") + " --config " + config.string() + " 2>&1", &output),
      0)
      << output;
  int epochs = 0;
  for (const auto& record : vln::test::readJsonLines(run / "metrics.jsonl"))
    if (record["type"] == "recollect") {
      ++epochs;
      EXPECT_GT(record["episodes"].get<int64_t>(), 0);
      // the ground truth replays exactly with sliding off
      EXPECT_EQ(record["off_ground_truth"].get<int64_t>(), 0) << record;
    }
  EXPECT_EQ(epochs, 2);
  EXPECT_EQ(listCheckpoints(run / "checkpoints").size(), 2u);
  EXPECT_FALSE(fs::exists(run / "store"));

  // a training episode's feature file missing: named before any replay
  data::RxrFilterConfig guide;
  const data::Episode first =
      data::readRxrEpisodes(w.data, "train", guide).front();
  const fs::path features = privateFeatures(w, dir_ / "private");
  const fs::path missing = data::rxrTextFeaturesPath(
      features, "train", *first.instruction.instruction_id,
      first.instruction.language);
  fs::remove(missing);
  fs::remove_all(run);
  const int code = vln::test::runCommand(
      binary("train") + " --config " + config.string() +
          " --set dataset.text_features_dir=" + features.string() + " 2>&1",
      &output);
  EXPECT_NE(code, 0);
  EXPECT_THAT(output, HasSubstr(missing.filename().string()));
  EXPECT_THAT(output, ::testing::Not(HasSubstr("recollect epoch")));
}

}  // namespace
}  // namespace vln::train
