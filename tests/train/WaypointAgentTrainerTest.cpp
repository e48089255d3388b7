// Tests src/train/WaypointAgentTrainer.cpp end to end on the tiny world: the
// `train` binary runs trainer.task waypoint_cma (DAgger over candidate
// waypoints from a predictor weight file), writes checkpoints, validation
// stats and the best checkpoint; `eval` scores a checkpoint like any other;
// --resume and bad configs are refused with the key named.

#include "train/WaypointAgentTrainer.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "models/StateDict.h"
#include "models/WaypointPredictor.h"
#include "rollout/SplitEvaluation.h"
#include "support/TestPaths.h"
#include "support/TestUtil.h"
#include "train/Checkpoint.h"
#include "train/TinyWorldBinaryTest.h"

namespace vln::train {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using vln::test::binary;

class WaypointAgentTrainerTest : public test::TinyWorldBinaryTest {
 protected:
  WaypointAgentTrainerTest() : TinyWorldBinaryTest("train") {}

  // the tiny run plus the waypoint sections; the predictor's weights are a
  // random predictor of the config's network written here
  fs::path writeConfig(const std::string& agent) {
    const fs::path yaml = vln::test::writeText(
        dir_ / "config.yaml",
        test::tinyRunConfig(*world_, dir_ / "run",
                            "  task: waypoint_cma\n"
                            "  dagger_iterations: 2\n"
                            "  dagger_episodes: 6\n"
                            "  dagger_epochs: 1\n") +
            "panorama:\n"
            "  rgb: {width: 32, height: 32}\n"
            "  depth: {width: 32, height: 32}\n"
            "waypoint:\n"
            "  predictor: {hidden_size: 32, ff_size: 32}\n"
            "waypoint_agent:\n"
            "  predictor_weights: " +
            (dir_ / "predictor.pt").string() + "\n" + agent);
    const ExperimentConfig config = loadExperimentConfig(yaml);
    torch::manual_seed(0);
    models::WaypointPredictor predictor = models::makeWaypointPredictor(
        config.model, config.waypoint.predictor, config.panorama.num_views);
    models::saveModule(*predictor, dir_ / "predictor.pt");
    return yaml;
  }
};

TEST_F(WaypointAgentTrainerTest, TrainsAndEvaluatesLikeAnyAgent) {
  const fs::path config = writeConfig("  max_decisions: 6\n");
  std::string output;
  ASSERT_EQ(
      vln::test::runCommand(
          binary("train") + " --config " + config.string() + " 2>&1", &output),
      0)
      << output;
  const fs::path run = dir_ / "run";
  const auto checkpoints = listCheckpoints(run / "checkpoints");
  ASSERT_EQ(checkpoints.size(), 2u) << output;
  const Checkpoint last = loadCheckpoint(checkpoints.back());
  EXPECT_EQ(last.progress.dagger_iteration, 2);
  EXPECT_GT(last.progress.updates, 0);
  EXPECT_TRUE(fs::exists(run / "checkpoints" / "best.json"));
  for (int i : {0, 1})
    for (const char* split : {"val_seen", "val_unseen"})
      EXPECT_TRUE(fs::exists(run / "eval" / rollout::statsFileName(i, split)))
          << i << " " << split;
  // the teacher-forcing round follows the oracle, which reaches most goals
  const auto records = vln::test::readJsonLines(run / "metrics.jsonl");
  int collects = 0;
  for (const auto& r : records)
    if (r["type"] == "collect") {
      ++collects;
      if (r["iteration"] == 0) EXPECT_GE(r["success"].get<double>(), 0.5);
      EXPECT_GT(r["decisions"].get<int>(), 0);
    }
  EXPECT_EQ(collects, 2);

  // eval scores the checkpoint with the waypoint agent
  if (!fs::exists(binary("eval"))) GTEST_SKIP() << "build the eval binary";
  ASSERT_EQ(
      vln::test::runCommand(
          binary("eval") + " --config " + (run / "config.yaml").string() +
              " --checkpoint " + checkpoints.back().string() +
              " --split val_unseen --out " + (dir_ / "eval").string() + " 2>&1",
          &output),
      0)
      << output;
  const rollout::SplitStats stats = rollout::readStatsFile(
      dir_ / "eval" / rollout::statsFileName(1, "val_unseen"));
  EXPECT_GT(stats.num_episodes, 0);
  EXPECT_GT(stats.mean.path_length, 0.0);

  // a second run into the directory cannot resume
  EXPECT_NE(vln::test::runCommand(binary("train") + " --config " +
                                      config.string() + " --resume 2>&1",
                                  &output),
            0);
  EXPECT_THAT(output, HasSubstr("cannot resume"));
}

TEST_F(WaypointAgentTrainerTest, BadConfigsNameTheKey) {
  const ExperimentConfig good = loadExperimentConfig(writeConfig(""));
  EXPECT_NO_THROW(validateWaypointAgentConfig(good));
  ExperimentConfig c = good;
  c.panorama.depth.camera.width = 64;
  EXPECT_THROW(
      {
        try {
          validateWaypointAgentConfig(c);
        } catch (const std::invalid_argument& e) {
          EXPECT_THAT(e.what(), HasSubstr("panorama.depth"));
          EXPECT_THAT(e.what(), HasSubstr("waypoint_cma"));
          throw;
        }
      },
      std::invalid_argument);
  c = good;
  c.waypoint_agent.predictor_weights = (dir_ / "missing.pt").string();
  try {
    makeWaypointAgentModels(c, false);
    ADD_FAILURE() << "a missing predictor file must be an error";
  } catch (const std::runtime_error& e) {
    EXPECT_THAT(e.what(), HasSubstr("waypoint_agent.predictor_weights"));
    EXPECT_THAT(e.what(), HasSubstr("missing.pt"));
  }
  // the depth-only baseline needs no weights
  c.waypoint_agent.candidates = "depth_baseline";
  EXPECT_NO_THROW(validateWaypointAgentConfig(c));
  EXPECT_TRUE(makeWaypointAgentModels(c, false).predictor.is_empty());
}

}  // namespace
}  // namespace vln::train
