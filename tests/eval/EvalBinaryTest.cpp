// The `eval` binary end to end on the tiny procedural world (the world
// generator's output, shared with the trainer tests): a training checkpoint,
// a directory of them with skipping and best.json, a TorchScript export, the
// baselines, the nav-graph comparison, pictures, the tables subcommand,
// the test split scored from its hidden goals and error reports; and, when
// the train binary is built, that re-evaluating a trained run's checkpoint
// reproduces the trainer's own validation numbers, and the run's learning
// curve (eval curve).

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <torch/torch.h>

#include "common/Json.h"
#include "data/Split.h"
#include "eval/EvalCommands.h"
#include "eval/NavGraphEval.h"
#include "models/Export.h"
#include "models/ObservationEncoder.h"
#include "models/Policy.h"
#include "models/StateDict.h"
#include "rollout/Metrics.h"
#include "support/TestUtil.h"
#include "train/Checkpoint.h"
#include "train/ExperimentConfig.h"
#include "train/TinyWorldBinaryTest.h"
#include "train/TrainTestWorld.h"

namespace vln::train {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using vln::test::binary;

class EvalBinaryTest : public test::TinyWorldBinaryTest {
 protected:
  EvalBinaryTest() : TinyWorldBinaryTest("eval") {}
  void SetUp() override {
    TinyWorldBinaryTest::SetUp();
    if (IsSkipped()) return;
    configFile_ = vln::test::writeText(
        dir_ / "config.yaml",
        test::tinyRunConfig(*world_, dir_ / "run", "  epochs: 1\n"));
    config_ = loadExperimentConfig(configFile_);
  }

  // a policy checkpoint as the trainer writes it; the encoders come from
  // the trainer's seeded initialisation (no weight files in the config)
  fs::path writeCheckpoint(const fs::path& dir, int index, double actionGain) {
    torch::manual_seed(static_cast<uint64_t>(config_.trainer.seed));
    auto policy = models::makePolicy(config_.model);
    torch::NoGradGuard noGrad;
    for (auto& p : policy->named_parameters())
      if (p.key() == "action_head.weight") p.value().mul_(actionGain);
    Checkpoint ckpt;
    ckpt.config_yaml = experimentConfigYaml(config_);
    ckpt.policy = models::namedState(*policy);
    ckpt.progress.checkpoint_index = index;
    const fs::path file = dir / checkpointFileName(index);
    saveCheckpoint(file, ckpt);
    return file;
  }

  int eval(const std::string& args, std::string* output) {
    return vln::test::runCommand(
        binary("eval") + " --log-level warn " + args + " 2>&1", output);
  }

  fs::path configFile_;
  ExperimentConfig config_;
};

TEST_F(EvalBinaryTest, CheckpointDirectoryWithSkippingAndBest) {
  const fs::path ckpts = dir_ / "run" / "checkpoints";
  writeCheckpoint(ckpts, 0, 1.0);
  writeCheckpoint(ckpts, 1, 50.0);
  std::string output;
  ASSERT_EQ(eval("--config " + configFile_.string() + " --checkpoint " +
                     (ckpts / "ckpt.0.pth").string() + " --episodes 2",
                 &output),
            0)
      << output;
  // default output <output.dir>/eval, both eval.splits
  const fs::path out = dir_ / "run" / "eval";
  EXPECT_EQ(rollout::readStatsFile(out / rollout::statsFileName(0, "val_seen"))
                .num_episodes,
            2);
  EXPECT_EQ(
      rollout::readStatsFile(out / rollout::statsFileName(0, "val_unseen"))
          .num_episodes,
      2);
  EXPECT_THAT(output, HasSubstr("ckpt 0 val_seen: 2 episodes"));

  // the directory: checkpoint 0 is skipped, 1 evaluated, the best picked
  ASSERT_EQ(eval("--config " + configFile_.string() + " --checkpoint " +
                     ckpts.string() + " --episodes 2",
                 &output),
            0)
      << output;
  EXPECT_THAT(output,
              HasSubstr("ckpt 0 val_seen: skipped (already evaluated)"));
  EXPECT_THAT(output, HasSubstr("ckpt 1 val_unseen: 2 episodes"));
  const auto best = common::readJsonFile(out / "best.json");
  const double spl0 =
      rollout::readStatsFile(out / rollout::statsFileName(0, "val_unseen"))
          .mean.spl;
  const double spl1 =
      rollout::readStatsFile(out / rollout::statsFileName(1, "val_unseen"))
          .mean.spl;
  EXPECT_EQ(best["index"], spl1 > spl0 ? 1 : 0);
  EXPECT_DOUBLE_EQ(best["spl"].get<double>(), std::max(spl0, spl1));
  EXPECT_THAT(output, HasSubstr("best checkpoint: ckpt."));
}

// The test split as a local leaderboard: a dataset whose test split is the
// tiny world's val_unseen without goals and whose hidden/test/ holds their
// goals and ground truth; --test-ground-truth scores the test split as
// val_unseen scores, and the leaderboard file is still written.
TEST_F(EvalBinaryTest, TestGroundTruthScoresTheTestSplit) {
  const fs::path data = dir_ / "data";
  fs::create_directories(data);
  for (const char* entry : {"train", "val_seen", "val_unseen", "train_aug",
                            "embeddings.json.gz", "connectivity"})
    fs::create_symlink(world_->data / entry, data / entry);
  data::EpisodeDataset unseen =
      data::readEpisodes(data::splitEpisodesPath(world_->data, "val_unseen"));
  ASSERT_FALSE(unseen.episodes.empty());
  data::writeEpisodes(data::hiddenGoalsPath(data, "test"), unseen);
  fs::copy_file(data::splitGroundTruthPath(world_->data, "val_unseen"),
                data::hiddenGroundTruthPath(data, "test"));
  for (data::Episode& e : unseen.episodes) {
    e.goals.clear();
    e.reference_path.clear();
    e.geodesic_distance.reset();
  }
  data::writeEpisodes(data::splitEpisodesPath(data, "test"), unseen);

  const fs::path ckpt = writeCheckpoint(dir_.path(), 0, 1.0);
  const fs::path out = dir_ / "out";
  const std::string command = "--config " + configFile_.string() +
                              " --set dataset.data_path=" + data.string() +
                              " --checkpoint " + ckpt.string() + " --out " +
                              out.string();
  std::string output;
  ASSERT_EQ(eval(command +
                     " --split val_unseen --split test "
                     "--test-ground-truth " +
                     (data / "hidden").string(),
                 &output),
            0)
      << output;
  const rollout::SplitStats test =
      rollout::readStatsFile(out / rollout::statsFileName(0, "test"));
  const rollout::SplitStats reference =
      rollout::readStatsFile(out / rollout::statsFileName(0, "val_unseen"));
  EXPECT_EQ(test.num_episodes, reference.num_episodes);
  EXPECT_EQ(rollout::metricsToJson(test.mean),
            rollout::metricsToJson(reference.mean));
  EXPECT_EQ(rollout::readLeaderboardFile(
                out / rollout::predictionsFileName(0, "test"))
                .size(),
            static_cast<size_t>(test.num_episodes));
  EXPECT_THAT(output, HasSubstr("test: scored from the hidden goals"));

  // without it, leaderboard predictions only, as before
  fs::remove_all(out);
  ASSERT_EQ(eval(command + " --split test", &output), 0) << output;
  EXPECT_FALSE(fs::exists(out / rollout::statsFileName(0, "test")));
  EXPECT_TRUE(fs::exists(out / rollout::predictionsFileName(0, "test")));

  // errors name the option and the file
  EXPECT_EQ(eval(command + " --split test --test-ground-truth " +
                     (dir_ / "missing").string(),
                 &output),
            1);
  EXPECT_THAT(output,
              HasSubstr("eval: error: eval --test-ground-truth: "
                        "findHiddenFiles(): '" +
                        (dir_ / "missing").string() + "' does not exist"));
  EXPECT_EQ(eval(command + " --split val_unseen --test-ground-truth " +
                     (data / "hidden").string(),
                 &output),
            1);
  EXPECT_THAT(output, HasSubstr("(add --split test)"));
}

TEST_F(EvalBinaryTest, TorchScriptExportMatchesItsCheckpoint) {
  const fs::path ckpt = writeCheckpoint(dir_ / "ckpts", 3, 20.0);
  // the export of the same policy with the encoders the evaluation rebuilds
  torch::manual_seed(static_cast<uint64_t>(config_.trainer.seed));
  auto policy = models::makePolicy(config_.model);
  models::ObservationEncoder encoder(config_.model);
  models::loadStateStrict(*policy, loadCheckpoint(ckpt).policy, ckpt.string());
  models::exportPolicy(*policy, encoder.ptr().get(), dir_ / "policy.pt");

  std::string output;
  const std::string common =
      "--config " + configFile_.string() + " --split val_unseen --episodes 3";
  ASSERT_EQ(eval(common + " --checkpoint " + ckpt.string() + " --out " +
                     (dir_ / "a").string(),
                 &output),
            0)
      << output;
  ASSERT_EQ(eval(common + " --checkpoint " + (dir_ / "policy.pt").string() +
                     " --index 3 --out " + (dir_ / "b").string(),
                 &output),
            0)
      << output;
  EXPECT_EQ(rollout::readStatsFile(dir_ / "b" /
                                   rollout::statsFileName(3, "val_unseen")),
            rollout::readStatsFile(dir_ / "a" /
                                   rollout::statsFileName(3, "val_unseen")));
  const auto a = rollout::readEpisodesFile(
      dir_ / "a" / rollout::episodesFileName(3, "val_unseen"));
  const auto b = rollout::readEpisodesFile(
      dir_ / "b" / rollout::episodesFileName(3, "val_unseen"));
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i)
    EXPECT_EQ(a[i].record.actions, b[i].record.actions);
}

TEST_F(EvalBinaryTest, BaselinesNavGraphPicturesAndTables) {
  std::string output;
  const fs::path out = dir_ / "handcrafted";
  ASSERT_EQ(
      eval("--config " + configFile_.string() +
               " --agent handcrafted --split val_seen" + " --navgraph " +
               (world_->data / "connectivity").string() +
               " --maps 1 --videos 1 --video-format mp4 --out " + out.string(),
           &output),
      0)
      << output;
  EXPECT_THAT(output, HasSubstr("baseline handcrafted: "));
  EXPECT_THAT(output, HasSubstr("| nav-graph TL "));
  const auto stats =
      rollout::readStatsFile(out / rollout::statsFileName(0, "val_seen"));
  const auto graph =
      eval::readGraphStatsFile(out / eval::graphStatsFileName(0, "val_seen"));
  EXPECT_EQ(graph.num_episodes, stats.num_episodes);
  EXPECT_GT(stats.num_episodes, 0);
  size_t pictures = 0;
  for (const auto& e : fs::directory_iterator(out / "pictures")) {
    const std::string ext = e.path().extension().string();
    EXPECT_TRUE(ext == ".png" || ext == ".mp4") << e.path();
    ++pictures;
  }
  EXPECT_EQ(pictures, 2u);

  ASSERT_EQ(eval("--config " + configFile_.string() +
                     " --agent random --split val_unseen --out " +
                     (dir_ / "random").string(),
                 &output),
            0)
      << output;
  EXPECT_TRUE(
      fs::exists(dir_ / "random" / rollout::statsFileName(0, "val_unseen")));

  ASSERT_EQ(
      vln::test::runCommand(
          binary("eval") + " tables --runs " +
              (vln::test::testDataPath() / "eval" / "results").string() +
              " --out " + (dir_ / "docs" / "results.md").string() + " 2>&1",
          &output),
      0)
      << output;
  EXPECT_TRUE(fs::exists(dir_ / "docs" / "results.md"));
  EXPECT_TRUE(fs::exists(dir_ / "docs" / "results.tex"));

  // the seeds fixture: only its rows, then the paper's findings judged
  const std::string seeds =
      " --runs " + (vln::test::testDataPath() / "eval" / "seeds").string();
  ASSERT_EQ(eval("tables" + seeds + " --claimed-only --out " +
                     (dir_ / "claimed.md").string(),
                 &output),
            0)
      << output;
  EXPECT_THAT(output, HasSubstr("(2 tables, 5 rows of ours)"));
  ASSERT_EQ(
      eval("compare" + seeds + " --out " + (dir_ / "findings.md").string(),
           &output),
      0)
      << output;
  EXPECT_THAT(output, HasSubstr("1 hold, 1 do not hold"));
}

TEST_F(EvalBinaryTest, ErrorsAreReported) {
  std::string output;
  EXPECT_EQ(eval("--checkpoint x.pth", &output), 1);
  EXPECT_THAT(output, HasSubstr("eval: error: eval: --config is required"));

  // a checkpoint of another architecture: every mismatched tensor listed
  ExperimentConfig other = config_;
  other.model.hidden_size = 24;
  auto policy = models::makePolicy(other.model);
  Checkpoint ckpt;
  ckpt.config_yaml = experimentConfigYaml(other);
  ckpt.policy = models::namedState(*policy);
  saveCheckpoint(dir_ / "ckpt.5.pth", ckpt);
  EXPECT_EQ(eval("--config " + configFile_.string() + " --checkpoint " +
                     (dir_ / "ckpt.5.pth").string(),
                 &output),
            1);
  EXPECT_THAT(output, HasSubstr("ckpt.5.pth"));
  EXPECT_THAT(output, HasSubstr("action_head.weight"));

  vln::test::writeText(dir_ / "broken.pth", "not a checkpoint");
  EXPECT_EQ(eval("--config " + configFile_.string() + " --checkpoint " +
                     (dir_ / "broken.pth").string(),
                 &output),
            1);
  EXPECT_THAT(output, HasSubstr("broken.pth"));
  EXPECT_EQ(eval("--config " + configFile_.string() +
                     " --set eval.num_envs=0 --agent random",
                 &output),
            1);
  EXPECT_THAT(output, HasSubstr("eval.num_envs"));
}

// `eval --agent oracle --dump` end to end: the oracle succeeds, its first
// episode is dumped with one RGB and one depth image per frame, and bad
// dump flags are errors naming the flag.
TEST_F(EvalBinaryTest, OracleDumpsItsObservations) {
  std::string output;
  const fs::path dump = dir_ / "dump";
  ASSERT_EQ(eval("--config " + configFile_.string() +
                     " --agent oracle --split val_unseen --episodes 3 --out " +
                     (dir_ / "oracle").string() + " --dump " + dump.string() +
                     " --dump-episodes 1",
                 &output),
            0)
      << output;
  EXPECT_THAT(output, HasSubstr("oracle: trainer.expert goal"));
  const auto stats = rollout::readStatsFile(
      dir_ / "oracle" / rollout::statsFileName(0, "val_unseen"));
  EXPECT_EQ(stats.num_episodes, 3);
  EXPECT_EQ(stats.mean.success, 1.0);
  ASSERT_EQ(vln::test::countEntries(dump / "val_unseen"), 1);
  const fs::path episode = fs::directory_iterator(dump / "val_unseen")->path();
  const auto json = common::readJsonFile(episode / "episode.json");
  EXPECT_EQ(json["agent"], "oracle");
  EXPECT_EQ(json["metrics"]["success"], 1.0);
  // the tokens with their words from the split's vocabulary
  ASSERT_TRUE(json["instruction"]["words"].is_array());
  EXPECT_EQ(json["instruction"]["words"].size(),
            json["instruction"]["tokens"].size());
  EXPECT_FALSE(json["instruction"]["tokens"].empty());
  EXPECT_TRUE(json["instruction"]["words"][0].is_string());
  const int frames = json["num_frames"].get<int>();
  EXPECT_EQ(frames, json["num_actions"].get<int>() + 1);
  EXPECT_EQ(vln::test::countEntries(episode / "rgb"), frames);
  EXPECT_EQ(vln::test::countEntries(episode / "depth"), frames);
  EXPECT_EQ(vln::test::readJsonLines(episode / "steps.jsonl").size(),
            static_cast<size_t>(frames));

  // bad flags
  const std::string oracle =
      "--config " + configFile_.string() + " --agent oracle ";
  EXPECT_EQ(
      eval(oracle + "--dump " + dump.string() + " --dump-format gif", &output),
      1);
  EXPECT_THAT(output, HasSubstr("--dump-format must be png or jpg, got 'gif'"));
  EXPECT_EQ(eval(oracle + "--dump-episodes 2", &output), 1);
  EXPECT_THAT(output, HasSubstr("--dump-episodes needs --dump DIR"));
  EXPECT_EQ(
      eval(oracle + "--dump " + dump.string() + " --dump-ids 3,x", &output), 1);
  EXPECT_THAT(output, HasSubstr("--dump-ids: 'x' is not an episode id"));
}

// A short training run evaluates its checkpoints during training; the
// binary, re-evaluating the same checkpoint, must get the same numbers.
TEST_F(EvalBinaryTest, ReproducesTheTrainersValidation) {
  if (!fs::exists(binary("train")))
    GTEST_SKIP() << "build the train binary first";
  std::string output;
  ASSERT_EQ(vln::test::runCommand(
                binary("train") + " --config " + configFile_.string() + " 2>&1",
                &output),
            0)
      << output;
  const fs::path run = dir_ / "run";
  const auto checkpoints = listCheckpoints(run / "checkpoints");
  ASSERT_FALSE(checkpoints.empty()) << output;
  const int index = *checkpointIndex(checkpoints.back());
  const fs::path trainerStats =
      run / "eval" / rollout::statsFileName(index, "val_unseen");
  ASSERT_TRUE(fs::exists(trainerStats)) << output;
  ASSERT_EQ(
      eval("--config " + configFile_.string() + " --checkpoint " +
               checkpoints.back().string() + " --split val_unseen --episodes " +
               std::to_string(config_.eval.train_eval_episodes) + " --out " +
               (dir_ / "again").string(),
           &output),
      0)
      << output;
  EXPECT_EQ(rollout::readStatsFile(dir_ / "again" /
                                   rollout::statsFileName(index, "val_unseen")),
            rollout::readStatsFile(trainerStats));

  // the run's records: where the process started, the updates behind each
  // validation; and its learning curve drawn by eval curve
  const auto records = vln::test::readJsonLines(run / "metrics.jsonl");
  ASSERT_FALSE(records.empty());
  EXPECT_EQ(records.front()["type"], "start");
  EXPECT_EQ(records.front()["resumed"], false);
  const int64_t updates =
      common::readJsonFile(run / "finished.json")["updates"].get<int64_t>();
  EXPECT_GT(updates, 0);
  for (const auto& record : records) {
    if (record["type"] == "eval") {
      EXPECT_EQ(record["updates"], updates);
    }
  }
  ASSERT_EQ(eval("curve --run " + run.string() + " --out " +
                     (dir_ / "curve.png").string(),
                 &output),
            0)
      << output;
  EXPECT_THAT(output, HasSubstr("(1 validation of val_unseen; best SPL"));
  EXPECT_THAT(output, HasSubstr(std::to_string(updates) + " updates"));
  EXPECT_TRUE(fs::exists(dir_ / "curve.png"));
}

}  // namespace
}  // namespace vln::train
