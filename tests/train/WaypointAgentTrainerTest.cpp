// Tests src/train/WaypointAgentTrainer.cpp end to end on the tiny world: the
// `train` binary runs trainer.task waypoint_cma (DAgger over candidate
// waypoints from a predictor weight file), writes checkpoints, validation
// stats and the best checkpoint; `eval` scores a checkpoint like any other;
// `train --export` and `vlnce-export` write the policy as TorchScript that
// acts as the checkpoint does; --resume and bad configs are refused with the
// key named; waypoint_agent.execution teleport trains and evaluates;
// mirrored replays (waypoint_agent.mirror_probability) and the
// sub-instruction loss (waypoint_agent.sub_instruction_weight) train, and
// so does a label tolerance (acceptedSetLoss()); the leg-words diagnostic
// (waypoint_agent.leg_words_only) trains and evaluates; trainer.init_checkpoint
// starts a fine-tuning run from another run's weights.

#include "train/WaypointAgentTrainer.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include <torch/script.h>

#include "models/ModelTestUtil.h"
#include "models/StateDict.h"
#include "models/WaypointPredictor.h"
#include "rollout/ObservationBatch.h"
#include "rollout/SplitEvaluation.h"
#include "support/TestPaths.h"
#include "support/TestUtil.h"
#include "train/Checkpoint.h"
#include "train/TinyWorldBinaryTest.h"
#include "waypoint/WaypointHeatmap.h"
#include "world/ViewLabels.h"

namespace vln::train {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using ::testing::Not;
using ::testing::ThrowsMessage;
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

  // one teacher-forcing round of `config` with `sets` (" --set k=v" ...)
  // into `out`: its only checkpoint, and the train binary's output
  Checkpoint trainOnce(const fs::path& config, const std::string& sets,
                       const fs::path& out, std::string* log = nullptr) {
    std::string output;
    EXPECT_EQ(vln::test::runCommand(
                  binary("train") + " --config " + config.string() +
                      " --set trainer.dagger_iterations=1"
                      " --set trainer.eval_during_training=false" +
                      sets + " --set output.dir=" + out.string() + " 2>&1",
                  &output),
              0)
        << output;
    if (log != nullptr) *log = output;
    const auto checkpoints = listCheckpoints(out / "checkpoints");
    EXPECT_EQ(checkpoints.size(), 1u) << output;
    return checkpoints.empty() ? Checkpoint{}
                               : loadCheckpoint(checkpoints.back());
  }

  // `eval` of `run`'s last checkpoint on val_unseen (with `sets`) into
  // `out` succeeds and scores episodes
  void expectEvaluates(const fs::path& run, const fs::path& out,
                       const std::string& sets = "") {
    std::string output;
    ASSERT_EQ(
        vln::test::runCommand(
            binary("eval") + " --config " + (run / "config.yaml").string() +
                " --checkpoint " +
                listCheckpoints(run / "checkpoints").back().string() + sets +
                " --split val_unseen --out " + out.string() + " 2>&1",
            &output),
        0)
        << output;
    EXPECT_GT(
        rollout::readStatsFile(out / rollout::statsFileName(0, "val_unseen"))
            .num_episodes,
        0);
  }

  // `train --export` of `config` with `sets` fails before training, saying
  // `why`
  void expectExportRefused(const fs::path& config, const std::string& sets,
                           const std::string& why) {
    std::string output;
    EXPECT_NE(vln::test::runCommand(
                  binary("train") + " --config " + config.string() + sets +
                      " --set output.dir=" + (dir_ / "exported").string() +
                      " --export " + (dir_ / "refused.pt").string() + " 2>&1",
                  &output),
              0);
    EXPECT_THAT(output, HasSubstr(why));
    EXPECT_FALSE(fs::exists(dir_ / "exported" / "checkpoints"))
        << "trained before refusing";
  }
};

// the command line's settings that give the policy the views' true labels
// as its RGB features (waypoint_agent.view_labels)
std::string viewLabelSets() {
  return " --set model.no_rgb=false --set model.rgb_semantic_outputs=" +
         std::to_string(world::viewLabelSize()) +
         " --set waypoint_agent.view_labels=true";
}

// validateWaypointAgentConfig() refuses `config` with a message holding
// each of `says`
void expectRefused(const ExperimentConfig& config,
                   const std::vector<std::string>& says) {
  try {
    validateWaypointAgentConfig(config);
    ADD_FAILURE() << "accepted a config to be refused for " << says.front();
  } catch (const std::invalid_argument& e) {
    for (const std::string& part : says) EXPECT_THAT(e.what(), HasSubstr(part));
  }
}

// whether two checkpoints' policies differ in any weight
bool policiesDiffer(const Checkpoint& a, const Checkpoint& b) {
  EXPECT_EQ(a.policy.size(), b.policy.size());
  for (size_t i = 0; i < std::min(a.policy.size(), b.policy.size()); ++i)
    if (!torch::equal(a.policy[i].second, b.policy[i].second)) return true;
  return false;
}

// The TorchScript archive `file` gives the logits and recurrent state of
// `checkpoint`'s policy (with the run's frozen encoders) on a random
// panorama, masked candidate slots and a random instruction; and, when
// `withPredictor`, the candidates the agent's predictor and suppression
// propose on that panorama.
void expectExportActsAsCheckpoint(const fs::path& file,
                                  const fs::path& checkpoint,
                                  const ExperimentConfig& config,
                                  bool withPredictor) {
  SCOPED_TRACE(file.string());
  ExperimentConfig c = config;
  if (!withPredictor) c.waypoint_agent.candidates = "depth_baseline";
  WaypointAgentModels nets = makeWaypointAgentModels(c, false);
  models::loadStateStrict(*nets.policy, loadCheckpoint(checkpoint).policy,
                          checkpoint.string());
  nets.policy->eval();
  torch::jit::Module exported = torch::jit::load(file.string());

  torch::manual_seed(5);
  const int64_t views = c.panorama.num_views;
  const torch::Tensor rgb = torch::randint(
      0, 256, {2, views, c.panorama.rgb.height, c.panorama.rgb.width, 3},
      torch::kUInt8);
  const torch::Tensor depth =
      torch::rand({2, views, c.panorama.depth.camera.height,
                   c.panorama.depth.camera.width, 1});
  const torch::Tensor tokens =
      torch::randint(1, c.model.vocab_size, {2, 6}, torch::kInt64);
  const torch::Tensor candidates = torch::stack(
      {torch::rand({2, 3}) * 6.28, torch::rand({2, 3}) * 2.75 + 0.25}, -1);
  const torch::Tensor mask =
      torch::tensor({1, 1, 0, 1, 0, 0}, torch::kBool).view({2, 3});
  const torch::Tensor prev =
      torch::tensor({0.5f, 1.0f, -1.0f, 2.0f}).view({2, 2});
  const torch::Tensor notDone = torch::tensor({1.0f, 0.0f});
  const torch::Tensor hidden = torch::randn({2, 2, c.model.hidden_size});

  torch::NoGradGuard noGrad;
  const models::VisualFeatures f = nets.encoder->forward(rgb, depth);
  const models::WaypointPolicyOutputs expected = nets.policy->step(
      nets.policy->encodeInstruction(tokens),
      {f.rgb.reshape({2, views, -1}), f.depth.reshape({2, views, -1}),
       candidates, mask, prev, notDone},
      hidden);
  const auto out = exported
                       .forward({rgb, depth, tokens, candidates, mask, prev,
                                 notDone, hidden})
                       .toTuple();
  const torch::Tensor logits = out->elements()[0].toTensor();
  const torch::Tensor finite = torch::isfinite(expected.logits);
  ASSERT_EQ(logits.sizes(), (std::vector<int64_t>{2, 4}));
  EXPECT_TRUE(torch::equal(finite, torch::isfinite(logits)));
  EXPECT_TRUE(torch::allclose(logits.masked_fill(~finite, 0),
                              expected.logits.masked_fill(~finite, 0), 1e-4,
                              1e-5))
      << logits << "\n"
      << expected.logits;
  EXPECT_TRUE(torch::allclose(out->elements()[1].toTensor(), expected.hidden,
                              1e-4, 1e-5));

  ASSERT_EQ(exported.attr("has_predictor").toBool(), withPredictor);
  if (!withPredictor) return;
  // propose(): the predictor's softmax through heatmapNms(), slot by slot
  const auto proposed = exported.run_method("propose", rgb, depth).toTuple();
  const torch::Tensor slots = proposed->elements()[0].toTensor();
  const torch::Tensor real = proposed->elements()[1].toTensor();
  const int64_t k = c.waypoint.nms_max_candidates;
  ASSERT_EQ(slots.sizes(), (std::vector<int64_t>{2, k, 2}));
  const torch::Tensor probabilities =
      models::waypointProbabilities(
          nets.predictor->forward(f.depth.reshape({2, views, -1}),
                                  f.rgb.reshape({2, views, -1})))
          .contiguous();
  for (int64_t b = 0; b < 2; ++b) {
    const std::vector<waypoint::Candidate> picks = waypoint::heatmapNms(
        std::span<const float>(probabilities[b].data_ptr<float>(),
                               waypoint::kHeatmapSize),
        k, c.waypoint.nms_heading_radius, c.waypoint.nms_distance_radius,
        static_cast<float>(c.waypoint.nms_min_score));
    ASSERT_FALSE(picks.empty());
    for (int64_t j = 0; j < k; ++j) {
      const auto i = static_cast<size_t>(j);
      ASSERT_EQ(real[b][j].item<bool>(), i < picks.size()) << b << " " << j;
      if (i >= picks.size()) continue;
      EXPECT_EQ(slots[b][j][0].item<float>(), picks[i].heading) << b << " " << j;
      EXPECT_EQ(slots[b][j][1].item<float>(), picks[i].distance) << b << " " << j;
    }
  }
}

TEST_F(WaypointAgentTrainerTest, TrainsAndEvaluatesLikeAnyAgent) {
  const fs::path config = writeConfig("  max_decisions: 6\n");
  std::string output;
  // with the instruction-contrast loss on (trainer.instruction_contrast_weight)
  // and the learning rate halved per iteration
  ASSERT_EQ(vln::test::runCommand(
                binary("train") + " --config " + config.string() +
                    " --set trainer.instruction_contrast_weight=0.5"
                    " --set trainer.lr_decay=0.5 --export " +
                    (dir_ / "agent.pt").string() + " 2>&1",
                &output),
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
  int collects = 0, epochs = 0;
  std::vector<double> rates;
  for (const auto& r : records) {
    if (r["type"] == "epoch") {
      ++epochs;
      rates.push_back(r["lr"].get<double>());
      // a batch of different instructions: a positive, finite contrast
      EXPECT_GT(r["instruction_contrast"].get<double>(), 0.0);
      EXPECT_LT(r["instruction_contrast"].get<double>(), 10.0);
      // accuracy over all decisions and over each episode's first one
      for (const char* key : {"accuracy", "first_decision_accuracy"}) {
        ASSERT_TRUE(r.contains(key)) << key;
        EXPECT_GE(r[key].get<double>(), 0.0) << key;
        EXPECT_LE(r[key].get<double>(), 1.0) << key;
      }
    }
    if (r["type"] == "collect") {
      ++collects;
      if (r["iteration"] == 0) {
        EXPECT_GE(r["success"].get<double>(), 0.5);
      }
      EXPECT_GT(r["decisions"].get<int>(), 0);
    }
  }
  EXPECT_EQ(collects, 2);
  EXPECT_EQ(epochs, 2);
  ASSERT_EQ(rates.size(), 2u);
  EXPECT_EQ(rates[0], loadExperimentConfig(run / "config.yaml").trainer.lr);
  EXPECT_DOUBLE_EQ(rates[1], rates[0] * 0.5);

  // train --export wrote the best (or else the latest) checkpoint's policy
  const ExperimentConfig runConfig = loadExperimentConfig(run / "config.yaml");
  expectExportActsAsCheckpoint(dir_ / "agent.pt", bestOrLatestCheckpoint(run),
                               runConfig, /*withPredictor=*/true);

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

  // an ensemble of the checkpoint with itself chooses as the checkpoint
  // does; with the run's best as the member it runs and names it; a
  // directory of checkpoints cannot be ensembled
  auto ensembleEval = [&](const fs::path& checkpoint, const fs::path& member,
                          const fs::path& out) {
    return vln::test::runCommand(
        binary("eval") + " --config " + (run / "config.yaml").string() +
            " --checkpoint " + checkpoint.string() + " --ensemble " +
            member.string() + " --split val_unseen --out " + out.string() +
            " 2>&1",
        &output);
  };
  ASSERT_EQ(ensembleEval(checkpoints.back(), checkpoints.back(),
                         dir_ / "ensemble_self"),
            0)
      << output;
  EXPECT_THAT(output, HasSubstr("(choice probabilities averaged)"));
  const auto single = rollout::readEpisodesFile(
      dir_ / "eval" / rollout::episodesFileName(1, "val_unseen"));
  const auto doubled = rollout::readEpisodesFile(
      dir_ / "ensemble_self" / rollout::episodesFileName(1, "val_unseen"));
  ASSERT_FALSE(single.empty());
  ASSERT_EQ(doubled.size(), single.size());
  for (size_t i = 0; i < single.size(); ++i)
    EXPECT_EQ(doubled[i].record.actions, single[i].record.actions)
        << "episode " << i;
  ASSERT_EQ(ensembleEval(checkpoints.front(), run, dir_ / "ensemble_run"), 0)
      << output;
  EXPECT_THAT(output, HasSubstr((run / "checkpoints").string()));
  EXPECT_TRUE(fs::exists(dir_ / "ensemble_run" /
                         rollout::statsFileName(0, "val_unseen")));
  EXPECT_NE(ensembleEval(run / "checkpoints", run, dir_ / "ensemble_dir"), 0);
  EXPECT_THAT(output, HasSubstr("--checkpoint must be one checkpoint file"));

  // eval scores the export as the checkpoint it came from: the archive
  // proposes, the config's waypoint_agent executes, action for action
  const fs::path exportedFrom = bestOrLatestCheckpoint(run);
  const int exportedIndex = *checkpointIndex(exportedFrom);
  for (const auto& [what, out] :
       {std::pair{exportedFrom, dir_ / "from_checkpoint"},
        std::pair{dir_ / "agent.pt", dir_ / "from_export"}})
    ASSERT_EQ(vln::test::runCommand(
                  binary("eval") + " --config " +
                      (run / "config.yaml").string() + " --checkpoint " +
                      what.string() + " --index " +
                      std::to_string(exportedIndex) +
                      " --split val_unseen --out " + out.string() + " 2>&1",
                  &output),
              0)
        << output;
  const auto fromCheckpoint = rollout::readEpisodesFile(
      dir_ / "from_checkpoint" /
      rollout::episodesFileName(exportedIndex, "val_unseen"));
  const auto fromExport = rollout::readEpisodesFile(
      dir_ / "from_export" /
      rollout::episodesFileName(exportedIndex, "val_unseen"));
  ASSERT_FALSE(fromExport.empty());
  ASSERT_EQ(fromExport.size(), fromCheckpoint.size());
  for (size_t i = 0; i < fromExport.size(); ++i) {
    EXPECT_EQ(fromExport[i].record.actions, fromCheckpoint[i].record.actions)
        << "episode " << i;
    EXPECT_EQ(fromExport[i].metrics.success, fromCheckpoint[i].metrics.success);
  }

  // a second run into the directory cannot resume
  EXPECT_NE(vln::test::runCommand(binary("train") + " --config " +
                                      config.string() +
                                      " --set "
                                      "trainer.instruction_contrast_weight=0.5"
                                      " --set trainer.lr_decay=0.5"
                                      " --resume 2>&1",
                                  &output),
            0);
  EXPECT_THAT(output, HasSubstr("cannot resume"));

  // vlnce-export from a checkpoint with its embedded config, which names
  // the predictor; without its weight file, an error naming the key, and
  // with a config of the depth-only baseline's candidates, the policy alone
  if (!fs::exists(binary("vlnce-export")))
    GTEST_SKIP() << "build the vlnce-export binary";
  ASSERT_EQ(vln::test::runCommand(binary("vlnce-export") + " --checkpoint " +
                                      checkpoints.front().string() + " --out " +
                                      (dir_ / "again.pt").string() + " 2>&1",
                                  &output),
            0)
      << output;
  expectExportActsAsCheckpoint(dir_ / "again.pt", checkpoints.front(),
                               runConfig, /*withPredictor=*/true);
  fs::remove(dir_ / "predictor.pt");
  EXPECT_NE(vln::test::runCommand(binary("vlnce-export") + " --checkpoint " +
                                      checkpoints.front().string() + " --out " +
                                      (dir_ / "bare.pt").string() + " 2>&1",
                                  &output),
            0);
  EXPECT_THAT(output, HasSubstr("waypoint_agent.predictor_weights"));
  ExperimentConfig baseline = runConfig;
  baseline.waypoint_agent.candidates = "depth_baseline";
  const fs::path baselineConfig = dir_ / "baseline.yaml";
  vln::test::writeText(baselineConfig, common::configToYaml(baseline));
  ASSERT_EQ(vln::test::runCommand(binary("vlnce-export") + " --checkpoint " +
                                      checkpoints.front().string() +
                                      " --config " + baselineConfig.string() +
                                      " --out " + (dir_ / "bare.pt").string() +
                                      " 2>&1",
                                  &output),
            0)
      << output;
  expectExportActsAsCheckpoint(dir_ / "bare.pt", checkpoints.front(), baseline,
                               /*withPredictor=*/false);
  // eval runs that archive on the depth-only baseline's candidates, and
  // refuses to ask it for the predictor's
  ASSERT_EQ(vln::test::runCommand(binary("eval") + " --config " +
                                      baselineConfig.string() +
                                      " --checkpoint " +
                                      (dir_ / "bare.pt").string() +
                                      " --split val_unseen --out " +
                                      (dir_ / "bare_eval").string() + " 2>&1",
                                  &output),
            0)
      << output;
  EXPECT_NE(vln::test::runCommand(binary("eval") + " --config " +
                                      (run / "config.yaml").string() +
                                      " --checkpoint " +
                                      (dir_ / "bare.pt").string() +
                                      " --split val_unseen --out " +
                                      (dir_ / "bare_eval").string() + " 2>&1",
                                  &output),
            0);
  EXPECT_THAT(output, HasSubstr("waypoint_agent.candidates: depth_baseline"));
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
  // a predictor left without features, before any weights are read
  ExperimentConfig blind = good;
  blind.model.no_rgb = false;
  blind.model.no_depth = true;
  blind.waypoint.predictor.rgb = false;
  expectRefused(blind, {"waypoint.predictor.rgb is false"});
  // the depth-only baseline needs no weights
  c.waypoint_agent.candidates = "depth_baseline";
  EXPECT_NO_THROW(validateWaypointAgentConfig(c));
  EXPECT_TRUE(makeWaypointAgentModels(c, false).predictor.is_empty());
  // mirrored replays cannot be combined with the instruction contrast
  c = good;
  c.waypoint_agent.mirror_probability = 0.5;
  EXPECT_NO_THROW(validateWaypointAgentConfig(c));
  c.trainer.instruction_contrast_weight = 0.5;
  expectRefused(c, {"waypoint_agent.mirror_probability"});
  // accepted choices are bits of a 32-bit word
  c = good;
  c.waypoint_agent.label_tolerance = 0.5;
  EXPECT_NO_THROW(validateWaypointAgentConfig(c));
  c.waypoint_agent.max_candidates = 40;
  expectRefused(c, {"waypoint_agent.label_tolerance"});
  // the sub-instruction loss needs an instruction
  c = good;
  c.waypoint_agent.sub_instruction_weight = 1.0;
  EXPECT_NO_THROW(validateWaypointAgentConfig(c));
  c.model.no_instruction = true;
  expectRefused(c, {"waypoint_agent.sub_instruction_weight"});
  // the instruction contrast needs an instruction
  c = good;
  c.trainer.instruction_contrast_weight = 0.5;
  EXPECT_NO_THROW(validateWaypointAgentConfig(c));
  EXPECT_NO_THROW(c.validate());
  c.model.no_instruction = true;
  expectRefused(c, {"trainer.instruction_contrast_weight"});
  try {
    c.validate();
    ADD_FAILURE() << "no words to contrast, for any trainer";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("trainer.instruction_contrast_weight"));
  }
}

// acceptedSetLoss(): the cross-entropy when every row accepts its label
// alone, -log of the accepted choices' probability otherwise, unlabelled
// rows left out
TEST(AcceptedSetLossTest, IsMinusLogTheAcceptedProbability) {
  torch::manual_seed(3);
  const torch::Tensor logits = torch::randn({4, 3}, torch::requires_grad());
  const torch::Tensor labels = torch::tensor({0, 2, -1, 1}, torch::kLong);
  torch::Tensor acceptable = torch::zeros({4, 3}, torch::kBool);
  for (int64_t i : {0, 1, 3}) acceptable[i][labels[i].item<int64_t>()] = true;
  EXPECT_TRUE(torch::equal(
      acceptedSetLoss(logits, labels, acceptable),
      torch::nn::functional::cross_entropy(
          logits, labels,
          torch::nn::functional::CrossEntropyFuncOptions().ignore_index(-1))));

  // row 0 also accepts choice 1, row 3 accepts everything
  acceptable[0][1] = true;
  acceptable[3].fill_(true);
  const torch::Tensor loss = acceptedSetLoss(logits, labels, acceptable);
  const torch::Tensor p = torch::softmax(logits.detach(), 1);
  const double expected =
      (-std::log(p[0][0].item<double>() + p[0][1].item<double>()) -
       std::log(p[1][2].item<double>()) + 0.0) /
      3.0;
  EXPECT_NEAR(loss.item<double>(), expected, 1e-5);
  loss.backward();
  // the row that accepts every choice, and the unlabelled one, pull nothing
  EXPECT_NEAR(logits.grad()[3].abs().sum().item<double>(), 0.0, 1e-6);
  EXPECT_EQ(logits.grad()[2].abs().sum().item<double>(), 0.0);
  EXPECT_GT(logits.grad()[0].abs().sum().item<double>(), 0.0);
  // row 0 no longer asks to prefer choice 0 over choice 1
  EXPECT_NEAR(logits.grad()[0][0].item<double>(),
              logits.grad()[0][1].item<double>() *
                  (p[0][0].item<double>() / p[0][1].item<double>()),
              1e-6);

  const torch::Tensor none =
      acceptedSetLoss(logits, torch::full({4}, -1, torch::kLong), acceptable);
  EXPECT_EQ(none.item<double>(), 0.0);
  EXPECT_TRUE(none.requires_grad());
  EXPECT_THROW(acceptedSetLoss(logits, labels, acceptable.slice(1, 0, 2)),
               std::invalid_argument);
}

// instructionContrastLoss() on a tiny policy: ln 2 when every episode of
// the batch has the same words (swapping changes nothing), something else
// when they differ, and a gradient that reaches the instruction encoder
TEST(InstructionContrastLossTest, MeasuresHowMuchTheWordsDecide) {
  torch::manual_seed(31);
  const models::ModelConfig c = models::test::tinyConfig(models::PolicyType::kCma);
  constexpr int64_t kViews = 4, kSteps = 3, kBatch = 3, kSlots = 2;
  models::WaypointCmaPolicyImpl policy(c, kViews, 11, 13);
  models::WaypointPolicyInputs in;
  in.rgb = torch::randn({kSteps, kBatch, kViews, 11});
  in.depth = torch::rand({kSteps, kBatch, kViews, 13});
  in.candidates = torch::stack({torch::rand({kSteps, kBatch, kSlots}) * 6.0,
                                torch::rand({kSteps, kBatch, kSlots}) * 3.0},
                               -1);
  in.candidate_mask = torch::ones({kSteps, kBatch, kSlots}, torch::kBool);
  in.prev = torch::rand({kSteps, kBatch, 2});
  in.not_done = torch::ones({kSteps, kBatch});
  in.not_done[0] = 0;
  // every decision labelled but one (-1 is ignored)
  const torch::Tensor labels =
      torch::tensor({1, 0, 2, 2, 1, -1, 0, 1, 1}, torch::kInt64);

  std::vector<data::Episode> episodes(kBatch);
  episodes[0].instruction.instruction_tokens = {3, 4, 5, 6};
  episodes[1].instruction.instruction_tokens = {7, 8, 9, 10, 11, 12};
  episodes[2].instruction.instruction_tokens = {13, 2};
  auto lossOf = [&](const std::vector<const data::Episode*>& batch) {
    const models::EncodedInstruction own = policy.encodeInstruction(
        rollout::batchInstructions(batch, 20));
    const torch::Tensor logits =
        policy.forwardSequence(own, in, policy.initialHidden(kBatch))
            .logits.reshape({kSteps * kBatch, -1});
    return instructionContrastLoss(policy, in, logits, labels, batch, 20,
                                   torch::kCPU);
  };
  const std::vector<const data::Episode*> same(kBatch, &episodes[1]);
  EXPECT_NEAR(lossOf(same).item<double>(), std::log(2.0), 1e-6);

  const std::vector<const data::Episode*> differ{&episodes[0], &episodes[1],
                                                 &episodes[2]};
  const torch::Tensor loss = lossOf(differ);
  EXPECT_GT(std::abs(loss.item<double>() - std::log(2.0)), 1e-4);
  loss.backward();
  double encoderGradient = 0.0;
  for (const auto& p : policy.instruction_encoder->parameters())
    if (p.grad().defined()) encoderGradient += p.grad().abs().sum().item<double>();
  EXPECT_GT(encoderGradient, 0.0);
}

// clauseTargets() points each decision at the rule clause where the words
// of the leg ahead begin (the stop's where nothing is ahead), -1 at padding
TEST(ClauseTargetsTest, PointAtTheRuleClauseOfTheLegAhead) {
  data::Episode episode;
  episode.episode_id = 4;
  // rule clauses: walk ahead | then turn right | and go past the sofa . |
  // stop at the tv .
  episode.instruction.instruction_text =
      "Walk ahead, then turn right and go past the sofa. Stop at the tv.";
  episode.reference_path = {Vec3f(0, 0, 0), Vec3f(0, 0, -4), Vec3f(4, 0, -4),
                            Vec3f(4, 0, -8)};
  data::Episode unsaid = episode;  // only leg 0 is described
  SubInstructionTokensByEpisode tokens;
  tokens[&episode] = {{0, 2, 0}, {2, 5, 1}, {5, 11, 1}, {11, 16, 3}};
  tokens[&unsaid] = {{0, 2, 0}};
  std::vector<rollout::WaypointDecision> row(4);
  row[0].position = Vec3f(0, 0, -0.2f);  // leg 0
  row[1].position = Vec3f(0, 0, -3.8f);  // at the first turn: leg 1
  row[2].position = Vec3f(4, 0, -4.2f);  // leg 2, unsaid: the stop's words
  row[3].position = Vec3f(4, 0, -7.9f);  // at the goal: the stop
  std::vector<rollout::WaypointDecision> shortRow(1);
  shortRow[0].position = Vec3f(4, 0, -7.9f);
  const std::vector<const std::vector<rollout::WaypointDecision>*> rows{
      &row, &shortRow};
  const std::vector<const data::Episode*> episodes{&episode, &unsaid};
  const torch::Tensor targets = clauseTargets(rows, episodes, tokens);
  ASSERT_EQ(targets.sizes(), (torch::IntArrayRef{4, 2}));
  EXPECT_TRUE(torch::equal(targets.select(1, 0),
                           torch::tensor({0, 1, 3, 3}, torch::kLong)));
  // nothing described ahead: the last rule clause; then padding
  EXPECT_TRUE(torch::equal(targets.select(1, 1),
                           torch::tensor({3, -1, -1, -1}, torch::kLong)));
  data::Episode stranger = episode;
  const std::vector<const data::Episode*> unknown{&stranger, &unsaid};
  EXPECT_THAT([&] { clauseTargets(rows, unknown, tokens); },
              ThrowsMessage<std::invalid_argument>(
                  HasSubstr("episode 4 has no sub-instructions")));
}

// subInstructionTargets() marks the clauses of the leg ahead of each
// decision (or of the next described leg), and subInstructionLoss() is
// -log of the attention mass on them
TEST(SubInstructionLossTest, AsksTheAttentionToRestOnTheLegAhead) {
  data::Episode episode;
  // legs 0 (to z = -4), 1 (to x = 4), 2 (to z = -8); 3 = the stop
  episode.reference_path = {Vec3f(0, 0, 0), Vec3f(0, 0, -4), Vec3f(4, 0, -4),
                            Vec3f(4, 0, -8)};
  // tokens: [0, 2) leg 0, [2, 4) and [4, 5) leg 1, leg 2 unsaid, [6, 9) stop
  SubInstructionTokensByEpisode tokens;
  tokens[&episode] = {{0, 2, 0}, {2, 4, 1}, {4, 5, 1}, {6, 9, 3}};
  std::vector<rollout::WaypointDecision> row(4);
  row[0].position = Vec3f(0, 0, -0.2f);  // leg 0
  row[1].position = Vec3f(0, 0, -3.8f);  // at the first turn: leg 1
  row[2].position = Vec3f(4, 0, -4.2f);  // leg 2, unsaid: the stop's words
  row[3].position = Vec3f(4, 0, -7.9f);  // at the goal: the stop
  std::vector<rollout::WaypointDecision> shortRow(1);
  shortRow[0].position = Vec3f(0, 0, -1.0f);
  data::Episode untold = episode;  // no sub-instructions
  const std::vector<const std::vector<rollout::WaypointDecision>*> rows{
      &row, &shortRow, &row};
  const std::vector<const data::Episode*> episodes{&episode, &episode, &untold};
  const int64_t L = 8;  // the stop's last token falls beyond L
  const torch::Tensor targets =
      subInstructionTargets(rows, episodes, tokens, L);
  ASSERT_EQ(targets.sizes(), (torch::IntArrayRef{4, 3, L}));
  auto marked = [&](int64_t t, int64_t b) {
    std::vector<int64_t> out;
    for (int64_t k = 0; k < L; ++k)
      if (targets[t][b][k].item<float>() > 0.0f) out.push_back(k);
    return out;
  };
  EXPECT_EQ(marked(0, 0), (std::vector<int64_t>{0, 1}));
  EXPECT_EQ(marked(1, 0), (std::vector<int64_t>{2, 3, 4}));
  EXPECT_EQ(marked(2, 0), (std::vector<int64_t>{6, 7}));
  EXPECT_EQ(marked(3, 0), (std::vector<int64_t>{6, 7}));
  EXPECT_EQ(marked(0, 1), (std::vector<int64_t>{0, 1}));
  for (int64_t t = 1; t < 4; ++t) EXPECT_TRUE(marked(t, 1).empty()) << t;
  for (int64_t t = 0; t < 4; ++t) EXPECT_TRUE(marked(t, 2).empty()) << t;

  // uniform attention: -log(k / L) averaged over the decisions with targets
  const torch::Tensor uniform = torch::full({4, 3, L}, 1.0 / L);
  const double expected = -(std::log(2.0 / L) + std::log(3.0 / L) +
                            2.0 * std::log(2.0 / L) + std::log(2.0 / L)) /
                          5.0;
  EXPECT_NEAR(subInstructionLoss(uniform, targets).item<double>(), expected,
              1e-5);
  // all the attention on the targets: no loss; a gradient towards them
  const torch::Tensor onTargets =
      targets / targets.sum(-1, true).clamp_min(1.0);
  EXPECT_NEAR(subInstructionLoss(onTargets, targets).item<double>(), 0.0, 1e-6);
  torch::Tensor scores = torch::zeros({4, 3, L}, torch::requires_grad());
  subInstructionLoss(torch::softmax(scores, -1), targets).backward();
  EXPECT_LT(scores.grad()[0][0][0].item<double>(), 0.0);
  EXPECT_GT(scores.grad()[0][0][5].item<double>(), 0.0);
  // no targets at all: zero, still differentiable
  const torch::Tensor none =
      subInstructionLoss(uniform, torch::zeros_like(uniform));
  EXPECT_EQ(none.item<double>(), 0.0);
}

// the loss trains from the binary on the tiny world's sub-instruction files,
// and a split without its file is refused naming the option and the file
TEST_F(WaypointAgentTrainerTest, SubInstructionLossTrainsAndNeedsItsFiles) {
  const fs::path config = writeConfig("  max_decisions: 6\n");
  const fs::path run = dir_ / "sub";
  std::string output;
  ASSERT_EQ(
      vln::test::runCommand(binary("train") + " --config " + config.string() +
                                " --set trainer.dagger_iterations=1"
                                " --set trainer.eval_during_training=false"
                                " --set waypoint_agent.sub_instruction_weight=1"
                                " --set output.dir=" +
                                run.string() + " 2>&1",
                            &output),
      0)
      << output;
  int epochs = 0;
  for (const auto& r : vln::test::readJsonLines(run / "metrics.jsonl")) {
    if (r["type"] != "epoch") continue;
    ++epochs;
    EXPECT_GT(r["sub_instruction"].get<double>(), 0.0);
    EXPECT_LT(r["sub_instruction"].get<double>(), 20.0);
  }
  EXPECT_EQ(epochs, 1);

  // the same world without train_aug's file
  const fs::path copy = dir_ / "world";
  fs::copy(world_->data, copy, fs::copy_options::recursive);
  fs::remove(data::splitSubInstructionsPath(copy, "train_aug"));
  ExperimentConfig c = loadExperimentConfig(config);
  c.dataset.data_path = copy.string();
  c.trainer.use_aug = true;
  c.waypoint_agent.sub_instruction_weight = 1.0;
  const TrainingData data = TrainingData::load(c);
  ASSERT_TRUE(data.aug);
  try {
    loadSubInstructionTokens(c, data);
    ADD_FAILURE() << "a missing sub-instruction file must be an error";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("waypoint_agent.sub_instruction_weight"));
    EXPECT_THAT(e.what(), HasSubstr("train_aug_sub_instructions.json.gz"));
  }
  c.trainer.use_aug = false;
  const SubInstructionTokensByEpisode loaded =
      loadSubInstructionTokens(c, TrainingData::load(c));
  EXPECT_FALSE(loaded.empty());
}

// waypoint_agent.leg_words_only, a diagnostic, trains (every epoch at its
// cosine rate here), validates and evaluates from the binaries with the
// splits' sub-instruction files; without a split's file eval names the
// option and the file; it is not exported
TEST_F(WaypointAgentTrainerTest, LegWordsOnlyTrainsEvaluatesAndIsNotExported) {
  const fs::path config = writeConfig("  max_decisions: 6\n");
  const std::string legWords =
      " --set waypoint_agent.leg_words_only=true"
      " --set trainer.dagger_iterations=1 --set trainer.dagger_epochs=2"
      " --set trainer.lr_schedule=cosine";
  const fs::path run = dir_ / "legs";
  std::string output;
  ASSERT_EQ(vln::test::runCommand(
                binary("train") + " --config " + config.string() + legWords +
                    " --set output.dir=" + run.string() + " 2>&1",
                &output),
            0)
      << output;
  std::vector<double> rates;
  for (const auto& r : vln::test::readJsonLines(run / "metrics.jsonl"))
    if (r["type"] == "epoch") rates.push_back(r["lr"].get<double>());
  const double lr = loadExperimentConfig(config).trainer.lr;
  ASSERT_EQ(rates.size(), 2u);
  EXPECT_DOUBLE_EQ(rates[0], lr);
  EXPECT_DOUBLE_EQ(rates[1], lr / 2);
  for (int i : {0, 1})
    EXPECT_TRUE(
        fs::exists(run / "eval" / rollout::statsFileName(i, "val_unseen")));
  // the words ahead are not all the words: other weights than without
  const Checkpoint withLegs =
      loadCheckpoint(listCheckpoints(run / "checkpoints").front());
  // (the first epoch trains at the full rate under either schedule)
  const Checkpoint without = trainOnce(config, "", dir_ / "all_words");
  EXPECT_TRUE(policiesDiffer(withLegs, without));

  if (!fs::exists(binary("eval"))) GTEST_SKIP() << "build the eval binary";
  const fs::path checkpoint = listCheckpoints(run / "checkpoints").back();
  auto evaluate = [&](const std::string& sets, const fs::path& out) {
    return vln::test::runCommand(
        binary("eval") + " --config " + (run / "config.yaml").string() +
            " --checkpoint " + checkpoint.string() + sets +
            " --split val_unseen --out " + out.string() + " 2>&1",
        &output);
  };
  ASSERT_EQ(evaluate("", dir_ / "legs_eval"), 0) << output;
  EXPECT_GT(rollout::readStatsFile(dir_ / "legs_eval" /
                                   rollout::statsFileName(1, "val_unseen"))
                .num_episodes,
            0);
  const fs::path copy = dir_ / "world";
  fs::copy(world_->data, copy, fs::copy_options::recursive);
  fs::remove(data::splitSubInstructionsPath(copy, "val_unseen"));
  EXPECT_NE(evaluate(" --set dataset.data_path=" + copy.string(),
                     dir_ / "legs_eval_missing"),
            0);
  EXPECT_THAT(output, HasSubstr("waypoint_agent.leg_words_only"));
  EXPECT_THAT(output, HasSubstr("val_unseen_sub_instructions.json.gz"));

  expectExportRefused(config, legWords, "leg_words_only is a diagnostic");
}

// model.clause_tracker trains (its loss and accuracy in the epoch
// records), changes what the policy learns, and evaluates from the binary
// with no sub-instruction file for the split (the rule's clauses are the
// instruction's own); it is not exported
TEST_F(WaypointAgentTrainerTest, TheClauseTrackerTrainsAndEvaluatesOnItsOwn) {
  const fs::path config = writeConfig("  max_decisions: 6\n");
  const std::string tracker =
      " --set model.clause_tracker=true"
      " --set waypoint_agent.clause_teacher_probability=0.5";
  std::string log;
  const fs::path run = dir_ / "tracker";
  const Checkpoint tracked = trainOnce(config, tracker, run, &log);
  EXPECT_THAT(log, HasSubstr("clause tracker"));
  int epochs = 0;
  for (const auto& r : vln::test::readJsonLines(run / "metrics.jsonl")) {
    if (r["type"] != "epoch") continue;
    ++epochs;
    EXPECT_GT(r["clause_tracker"].get<double>(), 0.0);
    EXPECT_GE(r["clause_accuracy"].get<double>(), 0.0);
    EXPECT_LE(r["clause_accuracy"].get<double>(), 1.0);
  }
  EXPECT_EQ(epochs, 1);
  const Checkpoint plain = trainOnce(config, "", dir_ / "plain");
  EXPECT_GT(tracked.policy.size(), plain.policy.size());

  if (!fs::exists(binary("eval"))) GTEST_SKIP() << "build the eval binary";
  const fs::path copy = dir_ / "world";
  fs::copy(world_->data, copy, fs::copy_options::recursive);
  fs::remove(data::splitSubInstructionsPath(copy, "val_unseen"));
  expectEvaluates(run, dir_ / "tracker_eval",
                  " --set dataset.data_path=" + copy.string());
  // each decision records the clause its pointer read, from 0 up
  int decisions = 0;
  for (const rollout::EpisodeResult& e :
       rollout::readEpisodesFile(dir_ / "tracker_eval" /
                                 rollout::episodesFileName(0, "val_unseen"))) {
    int last = 0;
    for (const rollout::WaypointChoice& c : e.record.waypoint_choices) {
      EXPECT_GE(c.clause, last);
      EXPECT_LE(c.clause, last + 2);
      last = c.clause;
      ++decisions;
    }
  }
  EXPECT_GT(decisions, 0);

  expectExportRefused(config, tracker, "model.clause_tracker");
  // and without the training splits' sub-instruction files it names them
  fs::remove(data::splitSubInstructionsPath(copy, "train"));
  std::string output;
  EXPECT_NE(
      vln::test::runCommand(
          binary("train") + " --config " + config.string() + tracker +
              " --set dataset.data_path=" + copy.string() +
              " --set output.dir=" + (dir_ / "unsplit").string() + " 2>&1",
          &output),
      0);
  EXPECT_THAT(output, HasSubstr("model.clause_tracker"));
  EXPECT_THAT(output, HasSubstr("train_sub_instructions.json.gz"));
}

// waypoint_agent.execution teleport trains and evaluates from the binaries:
// the teacher-forcing round's oracle (labelling by teleport ends) reaches
// most goals; eval records one TELEPORT step per waypoint, and the same
// checkpoint walks when the command line says so
// every replay mirrored trains other weights than none, from the same
// collected decisions
TEST_F(WaypointAgentTrainerTest, MirroredReplaysTrain) {
  const fs::path config = writeConfig("  max_decisions: 6\n");
  const std::string mirror = " --set waypoint_agent.mirror_probability=";
  const Checkpoint plain = trainOnce(config, mirror + "0", dir_ / "plain");
  const Checkpoint mirrored =
      trainOnce(config, mirror + "1", dir_ / "mirrored");
  EXPECT_TRUE(policiesDiffer(plain, mirrored))
      << "mirroring every replay changed nothing";
}

// model.goal_match over the views' true labels trains from the binary (the
// labels reach the policy only through their match: no RGB projection),
// evaluates from its checkpoint, and is not exported (an archive sees
// images, not true labels); without the labels' layout in the RGB features
// it is refused, naming the key
TEST_F(WaypointAgentTrainerTest, TheGoalMatchTrainsAndEvaluates) {
  const fs::path config =
      writeConfig("  max_decisions: 6\n  candidates: depth_baseline\n");
  const std::string goal = viewLabelSets() + " --set model.goal_match=true";
  const fs::path run = dir_ / "goal";
  const Checkpoint trained = trainOnce(config, goal, run);
  bool stopHead = false, projection = false;
  for (const auto& [name, weight] : trained.policy) {
    stopHead = stopHead || name == "goal_stop.weight";
    projection = projection || name == "rgb_linear.weight";
  }
  EXPECT_TRUE(stopHead);
  EXPECT_FALSE(projection);

  if (fs::exists(binary("eval"))) expectEvaluates(run, dir_ / "goal_eval");

  ExperimentConfig c = loadExperimentConfig(config);
  c.waypoint_agent.candidates = "depth_baseline";
  c.model.no_rgb = false;
  c.model.goal_match = true;
  c.model.rgb_semantic_outputs = 7;
  expectRefused(c, {"model.goal_match", "got 7"});
  // (the views' true labels are the reason; over the semantic heads the
  // goal match is exported: WaypointExportTest, ScriptedWaypointModelTest)
  expectExportRefused(config, goal, "cannot be exported");
}

// trainer.init_checkpoint starts the policy from another run's weights (a
// run directory resolves to its best or last checkpoint), and with
// fine_tune_dagger the first round is already DAgger's (beta < 1): with a
// learning rate of 0 the fine-tuned weights are the base run's, a fresh
// run's are not; a missing checkpoint is named
TEST_F(WaypointAgentTrainerTest, FineTunesFromAnotherRunsWeights) {
  const fs::path config = writeConfig("  max_decisions: 6\n");
  const Checkpoint base = trainOnce(config, "", dir_ / "base");
  const std::string still = " --set trainer.lr=0";
  const std::string fineTune =
      still +
      " --set trainer.fine_tune_dagger=true"
      " --set trainer.dagger_beta=0.5 --set trainer.init_checkpoint=";
  const Checkpoint tuned =
      trainOnce(config, fineTune + (dir_ / "base").string(), dir_ / "tuned");
  EXPECT_FALSE(policiesDiffer(base, tuned))
      << "the fine-tuned policy did not start from the base run's weights";
  const Checkpoint fresh = trainOnce(config, still, dir_ / "fresh");
  EXPECT_TRUE(policiesDiffer(base, fresh));
  int collects = 0;
  for (const auto& r :
       vln::test::readJsonLines(dir_ / "tuned" / "metrics.jsonl")) {
    if (r["type"] == "start") {
      EXPECT_EQ(r["init_checkpoint"], (dir_ / "base").string());
    }
    if (r["type"] != "collect") continue;
    ++collects;
    EXPECT_DOUBLE_EQ(r["beta"].get<double>(), 0.5);
  }
  EXPECT_EQ(collects, 1);

  std::string output;
  EXPECT_NE(vln::test::runCommand(
                binary("train") + " --config " + config.string() + fineTune +
                    (dir_ / "nowhere.pth").string() + " --set output.dir=" +
                    (dir_ / "missing").string() + " 2>&1",
                &output),
            0);
  EXPECT_THAT(output, HasSubstr("nowhere.pth"));
}

// a tolerance that accepts every candidate the oracle did not rank far
// behind its choice trains other weights than the labels alone, and the
// log reports how often the policy's choice was an accepted one
TEST_F(WaypointAgentTrainerTest, LabelToleranceTrains) {
  const fs::path config = writeConfig("  max_decisions: 6\n");
  const std::string tolerance = " --set waypoint_agent.label_tolerance=";
  std::string log;
  const Checkpoint exact = trainOnce(config, tolerance + "0", dir_ / "exact");
  const Checkpoint tolerant =
      trainOnce(config, tolerance + "3", dir_ / "tolerant", &log);
  EXPECT_TRUE(policiesDiffer(exact, tolerant))
      << "accepting near-ties changed nothing";
  EXPECT_THAT(log, HasSubstr("an accepted choice"));
}

// the progress monitor's targets: (d0 - d) / d0 per decision, 0 at padding
// and where a distance is unknown, clipped on request
TEST(ProgressTargetsTest, AreTheProgressMadeTowardsTheGoal) {
  data::Episode episode;
  episode.geodesic_distance = 8.0f;
  data::Episode unknown;  // no info.geodesic_distance (a test split)
  std::vector<rollout::WaypointDecision> row(3);
  row[0].goal_distance = 8.0f;
  row[1].goal_distance = 2.0f;
  row[2].goal_distance = 28.0f;                        // walked away: below -1
  std::vector<rollout::WaypointDecision> shortRow(1);  // goal unreachable
  const std::vector<const std::vector<rollout::WaypointDecision>*> rows{
      &row, &shortRow, &row};
  const std::vector<const data::Episode*> episodes{&episode, &episode,
                                                   &unknown};
  const at::Tensor raw = progressTargets(rows, episodes, false);
  ASSERT_EQ(raw.sizes(), (torch::IntArrayRef{3, 3}));
  EXPECT_FLOAT_EQ(raw[0][0].item<float>(), 0.0f);
  EXPECT_FLOAT_EQ(raw[1][0].item<float>(), 0.75f);
  EXPECT_FLOAT_EQ(raw[2][0].item<float>(), -2.5f);
  for (int64_t t = 0; t < 3; ++t) {
    EXPECT_EQ(raw[t][1].item<float>(), 0.0f) << t;
    EXPECT_EQ(raw[t][2].item<float>(), 0.0f) << t;
  }
  EXPECT_FLOAT_EQ(progressTargets(rows, episodes, true)[2][0].item<float>(),
                  -1.0f);
  EXPECT_THROW(progressTargets(rows, std::span(episodes).first(2), false),
               std::invalid_argument);
}

// the progress monitor and the corridor oracle train from the binary, each
// to other weights than the recipe without them; the log reports the
// progress loss
TEST_F(WaypointAgentTrainerTest, ProgressMonitorAndCorridorOracleTrain) {
  const fs::path config = writeConfig("  max_decisions: 6\n");
  std::string log;
  // (the tiny run's model section turns the head on)
  const Checkpoint plain =
      trainOnce(config, " --set model.progress_monitor=false", dir_ / "plain");
  const Checkpoint monitored = trainOnce(
      config, " --set model.progress_monitor=true", dir_ / "monitored", &log);
  // the head is there, and its loss reaches the weights the two share
  bool hasHead = false, sharedDiffer = false;
  for (const auto& [name, weight] : monitored.policy) {
    hasHead = hasHead || name.find("progress_monitor") != std::string::npos;
    for (const auto& [plainName, plainWeight] : plain.policy)
      if (plainName == name && !torch::equal(plainWeight, weight))
        sharedDiffer = true;
  }
  EXPECT_TRUE(hasHead);
  EXPECT_TRUE(sharedDiffer) << "the progress loss changed no shared weight";
  EXPECT_THAT(log, HasSubstr("progress 0."));
  EXPECT_THAT(log, Not(HasSubstr("progress 0.0000)")));
  const Checkpoint corridor =
      trainOnce(config,
                " --set model.progress_monitor=false"
                " --set waypoint_agent.oracle=goal_near_path"
                " --set waypoint_agent.oracle_corridor=0.3",
                dir_ / "corridor");
  EXPECT_TRUE(policiesDiffer(plain, corridor))
      << "a narrow corridor changed no label";
}

// waypoint_agent.view_labels (a diagnostic): the policy's RGB projection
// reads the 50 labels per view and trains without an RGB encoder's
// weights; the config must size the features for them, and the run cannot
// be exported (refused before training)
TEST_F(WaypointAgentTrainerTest, ViewLabelsTrainAndAreNotExported) {
  const fs::path config =
      writeConfig("  max_decisions: 6\n  candidates: depth_baseline\n");
  const std::string labels = viewLabelSets();
  const Checkpoint trained = trainOnce(config, labels, dir_ / "labels");
  bool found = false;
  for (const auto& [name, weight] : trained.policy)
    if (name == "rgb_linear.weight") {
      found = true;
      EXPECT_EQ(weight.size(1), world::viewLabelSize());
    }
  EXPECT_TRUE(found) << "no RGB projection in the policy";

  ExperimentConfig c = loadExperimentConfig(config);
  c.waypoint_agent.candidates = "depth_baseline";
  c.waypoint_agent.view_labels = true;
  c.model.no_rgb = false;
  expectRefused(c, {"rgb_semantic_outputs", "view_labels"});

  expectExportRefused(config, labels, "cannot be exported");
}

TEST_F(WaypointAgentTrainerTest, TeleportingTrainsAndEvaluates) {
  const fs::path config =
      writeConfig("  max_decisions: 6\n  execution: teleport\n");
  EXPECT_EQ(loadExperimentConfig(config).waypoint_agent.execution,
            waypoint::Execution::kTeleport);
  std::string output;
  ASSERT_EQ(
      vln::test::runCommand(
          binary("train") + " --config " + config.string() + " 2>&1", &output),
      0)
      << output;
  const fs::path run = dir_ / "run";
  const auto checkpoints = listCheckpoints(run / "checkpoints");
  ASSERT_EQ(checkpoints.size(), 2u) << output;
  const auto records = vln::test::readJsonLines(run / "metrics.jsonl");
  int collects = 0;
  for (const auto& r : records)
    if (r["type"] == "collect") {
      ++collects;
      if (r["iteration"] == 0) {
        EXPECT_GE(r["success"].get<double>(), 0.5);
      }
    }
  EXPECT_EQ(collects, 2);
  const rollout::SplitStats trained = rollout::readStatsFile(
      run / "eval" / rollout::statsFileName(1, "val_unseen"));
  // a teleport is one step: at most max_decisions of them and a STOP
  EXPECT_LE(trained.mean.steps_taken, 7.0);

  if (!fs::exists(binary("eval"))) GTEST_SKIP() << "build the eval binary";
  ASSERT_EQ(vln::test::runCommand(
                binary("eval") + " --config " + (run / "config.yaml").string() +
                    " --set waypoint_agent.execution=teleport --checkpoint " +
                    checkpoints.back().string() + " --split val_unseen --out " +
                    (dir_ / "eval").string() + " 2>&1",
                &output),
            0)
      << output;
  const auto episodes = rollout::readEpisodesFile(
      dir_ / "eval" / rollout::episodesFileName(1, "val_unseen"));
  ASSERT_FALSE(episodes.empty());
  for (const rollout::EpisodeResult& e : episodes) {
    const auto& actions = e.record.actions;
    ASSERT_FALSE(actions.empty());
    EXPECT_LE(actions.size(), 7u);
    for (size_t k = 0; k + 1 < actions.size(); ++k)
      EXPECT_EQ(actions[k], static_cast<int>(sim::Action::kTeleport));
  }
  ASSERT_EQ(vln::test::runCommand(
                binary("eval") + " --config " + (run / "config.yaml").string() +
                    " --set waypoint_agent.execution=walk --checkpoint " +
                    checkpoints.back().string() + " --split val_unseen --out " +
                    (dir_ / "walk").string() + " 2>&1",
                &output),
            0)
      << output;
  const auto walked = rollout::readEpisodesFile(
      dir_ / "walk" / rollout::episodesFileName(1, "val_unseen"));
  ASSERT_EQ(walked.size(), episodes.size());
  for (const rollout::EpisodeResult& e : walked)
    for (int action : e.record.actions) EXPECT_LT(action, sim::kNumActions);
  // a bad execution is refused with the key named
  EXPECT_NE(vln::test::runCommand(
                binary("eval") + " --config " + (run / "config.yaml").string() +
                    " --set waypoint_agent.execution=fly --checkpoint " +
                    checkpoints.back().string() + " --split val_unseen --out " +
                    (dir_ / "bad").string() + " 2>&1",
                &output),
            0);
  EXPECT_THAT(output, HasSubstr("waypoint_agent.execution"));
}

TEST_F(WaypointAgentTrainerTest, ExecutionIsWalkOrTeleport) {
  const fs::path config = writeConfig("");
  EXPECT_EQ(loadExperimentConfig(config).waypoint_agent.execution,
            waypoint::Execution::kWalk);
  EXPECT_EQ(loadExperimentConfig(config, {"waypoint_agent.execution=teleport"})
                .waypoint_agent.execution,
            waypoint::Execution::kTeleport);
  try {
    loadExperimentConfig(config, {"waypoint_agent.execution=fly"});
    ADD_FAILURE() << "execution fly must be refused";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("waypoint_agent.execution"));
    EXPECT_THAT(e.what(), HasSubstr("fly"));
    EXPECT_THAT(e.what(), HasSubstr("teleport"));
  }
}

}  // namespace
}  // namespace vln::train
