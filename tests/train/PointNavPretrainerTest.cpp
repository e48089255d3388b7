// Tests of src/train/PointNavPretrainer.cpp (and the shared parts of
// src/train/PretrainTasks.cpp): config errors,
// skipped non-finite losses, the memory bound, and one tiny end-to-end run
// that must learn (its imitation loss falls and it beats the random agent
// on held-out houses) and whose depth encoder loads strictly into a VLN
// model's frozen depth encoder but not into a different one.

#include "train/PointNavPretrainer.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <map>

#include "common/Json.h"
#include "models/StateDict.h"
#include "support/TestPaths.h"
#include "train/PretrainCommon.h"
#include "train/PretrainTasks.h"
#include "train/PretrainTestUtil.h"

namespace vln::train {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

// Two small training houses and one held-out house, 32x32 depth, a small
// CNN and GRU: big enough for the policy to learn heading to the goal and
// stopping there, small enough for a few seconds of CPU.
ExperimentConfig tinyConfig(const fs::path& runDir) {
  ExperimentConfig c = test::tinyPretrainConfig("depth_pointnav", runDir);
  c.trainer.seed = 7;
  c.trainer.num_envs = 8;
  c.trainer.log_every_updates = 5;
  c.model.depth_projection_size = 32;
  c.task.max_episode_steps = 60;
  c.pretrain.train_houses = 2;
  c.pretrain.heldout_houses = 1;
  c.pretrain.house_seed = 4242;
  c.pretrain.samples = 48;
  c.pretrain.iterations = 3;
  c.pretrain.epochs_per_iteration = 3;
  c.pretrain.batch_size = 8;
  c.pretrain.lr = 3e-3;
  c.pretrain.hidden_size = 64;
  c.pretrain.eval_samples = 40;
  c.pretrain.min_goal_distance = 1.0f;
  c.pretrain.max_goal_distance = 4.0f;
  c.pretrain.success_distance = 0.3f;
  c.pretrain.encoder_out = (runDir / "depth_cnn.pt").string();
  c.output.tensorboard = true;
  return c;
}

void expectFiniteNumbers(const nlohmann::json& j, const std::string& path) {
  if (j.is_object()) {
    for (const auto& [key, value] : j.items()) expectFiniteNumbers(value, path + "." + key);
  } else if (j.is_array()) {
    for (size_t i = 0; i < j.size(); ++i) expectFiniteNumbers(j[i], path + "[" + std::to_string(i) + "]");
  } else {
    // nlohmann writes NaN and infinities as null
    EXPECT_FALSE(j.is_null()) << path << " is not a finite number";
    if (j.is_number()) {
      EXPECT_TRUE(std::isfinite(j.get<double>())) << path;
    }
  }
}

// ---------------------------------------------------------------------------
// config errors

TEST(PointNavPretrainerTest, BadConfigValuesAreNamed) {
  vln::test::TempDir dir;
  auto expectError = [&](const std::function<void(ExperimentConfig&)>& change,
                         const std::string& key) {
    ExperimentConfig c = tinyConfig(dir.path());
    change(c);
    try {
      validatePretrainConfig(c);
      ADD_FAILURE() << "accepted a bad " << key;
    } catch (const std::invalid_argument& e) {
      EXPECT_THAT(e.what(), HasSubstr(key));
    }
  };
  expectError([](ExperimentConfig& c) { c.pretrain.min_goal_distance = 0.2f; },
              "pretrain.success_distance (0.3)");
  expectError([](ExperimentConfig& c) { c.pretrain.max_goal_distance = 0.5f; },
              "pretrain.max_goal_distance (0.5)");
  expectError([](ExperimentConfig& c) { c.model.no_depth = true; }, "model.no_depth");
  expectError([](ExperimentConfig& c) { c.sim.depth.camera.width = 48; }, "sim.depth.width");
  expectError([](ExperimentConfig& c) { c.pretrain.house.min_rooms = 5; }, "pretrain.house");
  expectError([](ExperimentConfig& c) { c.trainer.task = "vln"; }, "trainer.task");
}

TEST(PointNavPretrainerTest, MemoryBoundIsEnforced) {
  vln::test::TempDir dir;
  ExperimentConfig c = tinyConfig(dir.path());
  c.pretrain.samples = 100;  // 1 to 4 m each: well over 1,000 frames
  c.pretrain.iterations = 1;
  c.pretrain.max_memory_gib = 1e-3;  // 1 MiB: about 500 frames of 32x32
  PointNavPretrainer pretrainer(c, dir.path());
  try {
    pretrainer.run();
    FAIL() << "the frames fit in 1 MiB?";
  } catch (const std::runtime_error& e) {
    EXPECT_THAT(e.what(), HasSubstr("pretrain.max_memory_gib = 0.001"));
  }
}

// ---------------------------------------------------------------------------
// steps shared with the RGB task (PretrainCommon.h)

TEST(NonFiniteLossesTest, CountsAndGivesUpInARowNamingTheModel) {
  ExperimentConfig c;
  c.trainer.max_nonfinite_updates = 2;
  // the skip that makes two in a row throws exactly `message`
  auto expectGivesUp = [&](NonFiniteLosses& losses, const std::string& task,
                           const std::string& model, int64_t update,
                           const std::string& message) {
    try {
      losses.skip(c, task, model, update);
      FAIL() << "two in a row were allowed";
    } catch (const std::runtime_error& e) {
      EXPECT_STREQ(e.what(), message.c_str());
    }
  };
  NonFiniteLosses losses;
  losses.skip(c, "depth_pointnav", "blind control", /*update=*/7);
  EXPECT_EQ(losses.inARow, 1);
  EXPECT_EQ(losses.total, 1);
  expectGivesUp(
      losses, "depth_pointnav", "blind control", 8,
      "depth_pointnav: 2 non-finite losses in a row for the blind control "
      "(trainer.max_nonfinite_updates = 2); lower pretrain.lr");
  EXPECT_EQ(losses.total, 2);
  // a task's only model goes unnamed
  NonFiniteLosses single;
  single.skip(c, "rgb_semantic", "", 1);
  single.inARow = 0;  // an applied update in between
  single.skip(c, "rgb_semantic", "", 3);
  EXPECT_EQ(single.total, 2);
  expectGivesUp(single, "rgb_semantic", "", 4,
                "rgb_semantic: 2 non-finite losses in a row "
                "(trainer.max_nonfinite_updates = 2); lower pretrain.lr");
}

// ---------------------------------------------------------------------------
// end to end

TEST(PointNavPretrainerTest, ACosineScheduleAnnealsEachIterationsEpochs) {
  vln::test::TempDir dir;
  ExperimentConfig c = tinyConfig(dir.path());
  c.pretrain.iterations = 2;
  c.pretrain.epochs_per_iteration = 2;
  c.pretrain.samples = 16;
  c.pretrain.eval_samples = 4;
  c.pretrain.lr_schedule = "cosine";
  PointNavPretrainer(c, dir.path()).run();
  const std::vector<double> rates =
      test::epochLearningRates(dir / "metrics.jsonl");
  // each DAgger iteration's two epochs at lr, then lr x (1 + cos(pi / 2)) / 2
  const double lr = c.pretrain.lr;
  EXPECT_THAT(rates, ::testing::ElementsAre(::testing::DoubleEq(lr),
                                            ::testing::DoubleEq(0.5 * lr),
                                            ::testing::DoubleEq(lr),
                                            ::testing::DoubleEq(0.5 * lr)));
}

TEST(PointNavPretrainerTest, LearnsAndSavesALoadableDepthEncoder) {
  vln::test::TempDir dir;
  const ExperimentConfig c = tinyConfig(dir.path());
  PointNavPretrainer pretrainer(c, dir.path());
  const PointNavResult r = pretrainer.run();

  // it learned: the imitation loss fell a lot, and on the held-out house the
  // policy beats habitat's random agent (which even stops by the sensor)
  EXPECT_LT(r.final_loss, 0.5 * r.initial_loss)
      << "initial " << r.initial_loss << " final " << r.final_loss;
  EXPECT_GT(r.policy.success, r.random.success + 0.1)
      << "policy " << r.policy.success << " random " << r.random.success;
  EXPECT_GT(r.policy.spl, r.random.spl);
  // the follower reaches nearly every goal (the upper bound is sane)
  EXPECT_GE(r.oracle.success, 0.95);
  EXPECT_EQ(r.policy.episodes, 40);
  EXPECT_GT(r.frames, 3 * 48);

  // the summary file: every number finite
  const nlohmann::json summary = common::readJsonFile(dir / "pretrain_metrics.json");
  expectFiniteNumbers(summary, "pretrain_metrics");
  EXPECT_EQ(summary["task"], "depth_pointnav");
  EXPECT_DOUBLE_EQ(summary["heldout"]["policy"]["success"].get<double>(), r.policy.success);
  EXPECT_DOUBLE_EQ(summary["heldout"]["random"]["spl"].get<double>(), r.random.spl);

  // metrics.jsonl: one collect per iteration, one epoch per epoch, four evals
  std::map<std::string, int> types;
  for (const auto& line : test::readJsonLines(dir / "metrics.jsonl")) ++types[line["type"]];
  EXPECT_EQ(types["collect"], 3);
  EXPECT_EQ(types["epoch"], 9);
  // the default schedule keeps pretrain.lr
  EXPECT_THAT(test::epochLearningRates(dir / "metrics.jsonl"),
              ::testing::Each(::testing::DoubleEq(c.pretrain.lr)));
  EXPECT_EQ(types["eval"], 4);
  EXPECT_EQ(types["finished"], 1);
  EXPECT_GT(types["update"], 0);
  EXPECT_FALSE(fs::is_empty(dir / "tb"));

  // the encoder loads strictly, frozen, into a VLN model's depth encoder
  ASSERT_EQ(r.encoder_file, dir / "depth_cnn.pt");
  models::ModelConfig vln = c.model;
  vln.depth_weights = r.encoder_file.string();
  models::ObservationEncoder encoder(vln);
  encoder->loadPretrained();
  test::expectLoadedFrozen(models::readTensorFile(r.encoder_file),
                           models::namedState(encoder->depth->cnnModule()));
  EXPECT_TRUE(fs::exists(dir / "pointnav_policy.pt"));

  // ... and not into a different encoder: every mismatch is listed
  models::ModelConfig other = vln;
  other.depth_encoder = models::EncoderType::kResNet18;
  other.depth_width = other.depth_height = 64;
  test::expectLoadRejected(
      other, "a small CNN's tensors loaded into a ResNet-18",
      {"depth_cnn.pt", "cnn.0.weight", "backbone.conv1.0.weight"});
  // a depth CNN as RGB weights: same names, other input channels
  models::ModelConfig asRgb = c.model;
  asRgb.rgb_weights = r.encoder_file.string();
  test::expectLoadRejected(
      asRgb, "1-channel depth weights loaded into the 3-channel RGB CNN",
      {"cnn.0.weight"});
}

}  // namespace
}  // namespace vln::train
