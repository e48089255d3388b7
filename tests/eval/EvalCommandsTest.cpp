// The eval command's functions on a dataset written from the test house:
// a checkpoint, a directory of checkpoints (skipping and best selection), a
// TorchScript export, the baselines, the test split's leaderboard file and
// its scoring from hidden goals, the nav-graph comparison, error reports,
// and the tables subcommand, on
// checkpoints in the trainer's format; the binary itself is exercised in
// EvalBinaryTest.cpp.

#include "eval/EvalCommands.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <sstream>

#include "common/FileIo.h"
#include "common/Json.h"
#include "data/NavGraph.h"
#include "data/Split.h"
#include "eval/BaselineAgents.h"
#include "eval/Tables.h"
#include "models/Export.h"
#include "models/StateDict.h"
#include "rollout/Evaluator.h"
#include "rollout/PolicyAgent.h"
#include "rollout/RolloutTestPolicy.h"
#include "rollout/RolloutTestWorld.h"
#include "support/TestUtil.h"
#include "train/Checkpoint.h"
#include "viz/EpisodePictures.h"

namespace vln::eval {
namespace {

namespace fs = std::filesystem;
using rollout::test::rolloutTestWorld;
using ::testing::HasSubstr;

constexpr int kSeed = 13;  // a policy seed whose argmax actions vary

std::string checkpointName(int i) { return "ckpt." + std::to_string(i) + ".pth"; }

// a checkpoint of the trainer's format holding `policy`'s weights
void writePolicyCheckpoint(const fs::path& file, models::PolicyImpl& policy) {
  train::Checkpoint checkpoint;
  checkpoint.policy = models::namedState(policy);
  train::saveCheckpoint(file, checkpoint);
}

class EvalCommandsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto& w = rolloutTestWorld();
    rollout::test::writeDataset(w, dir_ / "data");
    settings_.sim = w.sim;
    settings_.task = w.task;
    settings_.dataset.data_path = (dir_ / "data").string();
    settings_.model = rollout::test::tinyModel(models::PolicyType::kCma);
    settings_.eval.num_envs = 2;
    settings_.eval.threads = 2;
    settings_.eval.map_episodes = 0;
    settings_.trainer.torch_threads = 1;
    settings_.trainer.seed = kSeed;
    settings_.output.dir = (dir_ / "run").string();
    // the trainer's construction under trainer.seed: the policy, then the
    // encoders, whose random weights the evaluation rebuilds
    model_ = rollout::test::tinyAgentModel(models::PolicyType::kCma, kSeed);
  }

  // a checkpoint: the policy with its action head scaled by `gain`
  fs::path writeCheckpoint(const fs::path& file, double gain) {
    auto copy = models::makePolicy(settings_.model);
    models::loadStateStrict(*copy, models::namedState(*model_.policy));
    torch::NoGradGuard noGrad;
    for (auto& p : copy->named_parameters())
      if (p.key() == "action_head.bias") p.value().mul_(gain);
    writePolicyCheckpoint(file, *copy);
    return file;
  }

  // what rollout::evaluateEpisodes gives for the in-memory model on a split
  rollout::SplitStats direct(const std::string& split) {
    const auto& w = rolloutTestWorld();
    const auto root = dir_ / "data";
    const auto episodes = data::readEpisodes(data::splitEpisodesPath(root, split)).episodes;
    const auto gt = data::readGroundTruth(data::splitGroundTruthPath(root, split));
    rollout::PolicyAgent agent(model_.policy, model_.encoder, 2, false, 0, 200);
    rollout::VectorEnv envs(2, w.sim, w.task,
                            std::make_shared<rollout::SceneCache>(w.sim), 1);
    return rollout::evaluateEpisodes(agent, envs, episodes, &gt, settings_.eval)
        .stats;
  }

  EvalCommandResult run(const EvalCommandOptions& options, std::string* printed = nullptr) {
    std::ostringstream out;
    EvalCommandResult r = runEvaluation(options, settings_, out);
    if (printed) *printed = out.str();
    return r;
  }

  vln::test::TempDir dir_;
  train::ExperimentConfig settings_;
  rollout::test::TinyAgentModel model_;
};

TEST_F(EvalCommandsTest, OneCheckpointWritesStatsEpisodesAndSummaries) {
  const fs::path ckpt = writeCheckpoint(dir_ / "ckpt.4.pth", 1.0);
  EvalCommandOptions options;
  options.checkpoint = ckpt;
  std::string printed;
  const EvalCommandResult r = run(options, &printed);

  // default output directory <output.dir>/eval, as the trainer's
  const fs::path out = dir_ / "run" / "eval";
  ASSERT_EQ(r.reports.size(), 2u);
  for (const std::string split : {"val_seen", "val_unseen"}) {
    SCOPED_TRACE(split);
    const rollout::SplitStats stats =
        rollout::readStatsFile(out / rollout::statsFileName(4, split));
    // exactly what the in-memory policy scores
    EXPECT_EQ(stats, direct(split));
    EXPECT_EQ(stats.num_episodes, 5);
    const auto episodes =
        rollout::readEpisodesFile(out / rollout::episodesFileName(4, split));
    ASSERT_EQ(episodes.size(), 5u);
    EXPECT_GT(episodes[0].record.steps_taken, 0);
    EXPECT_THAT(printed, HasSubstr("ckpt 4 " + split + ": 5 episodes, "));
  }
  EXPECT_FALSE(fs::exists(out / "best.json"));  // only directories pick a best
  EXPECT_THAT(printed, ::testing::MatchesRegex(
                           "(.*\n)?ckpt 4 val_seen: 5 episodes, [0-9]+ steps in [0-9.]+ s "
                           "\\([0-9.]+ episodes/s, [0-9]+ steps/s\\): TL [0-9.]+ NE [0-9.]+ "
                           "nDTW [0-9.]+ OS [0-9.]+ SR [0-9.]+ SPL [0-9.]+\n(.*\n)*"));
}

TEST_F(EvalCommandsTest, DirectorySkipsEvaluatedCheckpointsAndPicksTheBest) {
  const fs::path ckpts = dir_ / "checkpoints";
  for (int i : {1, 2, 3}) writeCheckpoint(ckpts / checkpointName(i), 1.0 + 0.5 * i);
  const fs::path out = dir_ / "out";
  // checkpoints 1 and 3 were evaluated before (by the trainer, say)
  rollout::SplitStats seen1, unseen1, seen3, unseen3;
  seen1.num_episodes = unseen1.num_episodes = seen3.num_episodes = unseen3.num_episodes = 5;
  unseen1.mean.spl = 0.25;
  unseen3.mean.spl = 0.5;
  seen3.mean.spl = 0.9;
  rollout::writeStatsFile(out, 1, "val_seen", seen1);
  rollout::writeStatsFile(out, 1, "val_unseen", unseen1);
  rollout::writeStatsFile(out, 3, "val_seen", seen3);
  rollout::writeStatsFile(out, 3, "val_unseen", unseen3);

  EvalCommandOptions options;
  options.checkpoint = ckpts;
  options.out = out;
  std::string printed;
  const EvalCommandResult r = run(options, &printed);
  ASSERT_EQ(r.reports.size(), 6u);
  for (const auto& report : r.reports)
    EXPECT_EQ(report.skipped, report.checkpoint != 2) << report.checkpoint << " " << report.split;
  EXPECT_THAT(printed, HasSubstr("ckpt 3 val_unseen: skipped (already evaluated): "));
  EXPECT_TRUE(fs::exists(out / rollout::statsFileName(2, "val_seen")));
  // the best by val_unseen SPL (the selection split), not val_seen
  const double spl2 =
      rollout::readStatsFile(out / rollout::statsFileName(2, "val_unseen"))
          .mean.spl;
  const int best = spl2 > 0.5 ? 2 : 3;
  ASSERT_TRUE(r.best_checkpoint.has_value());
  EXPECT_EQ(*r.best_checkpoint, best);
  const auto json = common::readJsonFile(out / "best.json");
  EXPECT_EQ(json["index"], best);
  EXPECT_EQ(json["checkpoint"], checkpointName(best));
  EXPECT_EQ(json["split"], "val_unseen");
  EXPECT_THAT(printed, HasSubstr("best checkpoint: " + checkpointName(best)));

  // everything evaluated: a second run evaluates nothing
  const EvalCommandResult again = run(options);
  for (const auto& report : again.reports) EXPECT_TRUE(report.skipped);
  EXPECT_EQ(again.best_checkpoint, r.best_checkpoint);
}

TEST_F(EvalCommandsTest, TorchScriptExportScoresLikeTheCheckpoint) {
  const fs::path ckpt = writeCheckpoint(dir_ / "ckpt.0.pth", 1.0);
  models::exportPolicy(*model_.policy, model_.encoder.ptr().get(), dir_ / "policy.pt");
  EvalCommandOptions options;
  options.checkpoint = ckpt;
  options.out = dir_ / "a";
  options.splits = {"val_unseen"};
  run(options);
  options.checkpoint = dir_ / "policy.pt";
  options.out = dir_ / "b";
  options.index = 7;
  run(options);
  EXPECT_EQ(rollout::readStatsFile(dir_ / "b" /
                                   rollout::statsFileName(7, "val_unseen")),
            rollout::readStatsFile(dir_ / "a" /
                                   rollout::statsFileName(0, "val_unseen")));
}

TEST_F(EvalCommandsTest, BaselinesUseTheTrainingGroundTruth) {
  const auto& w = rolloutTestWorld();
  const BaselineStatistics expected = baselineStatistics(w.groundTruth, sim::AgentConfig{});
  for (const std::string agent : {"random", "handcrafted"}) {
    SCOPED_TRACE(agent);
    EvalCommandOptions options;
    options.agent = agent;
    options.out = dir_ / agent;
    options.splits = {"val_seen"};
    std::string printed;
    run(options, &printed);
    EXPECT_THAT(printed, HasSubstr("(" + std::to_string(expected.forward_steps) +
                                   " forward steps, up to 24 turns)"));
    const auto episodes = rollout::readEpisodesFile(
        dir_ / agent / rollout::episodesFileName(0, "val_seen"));
    ASSERT_EQ(episodes.size(), 5u);
    if (agent == "handcrafted") {
      // turns, then the mean training path length in forward steps, STOP
      for (const auto& e : episodes) {
        int forward = 0;
        for (int a : e.record.actions) forward += a == 1;
        EXPECT_EQ(forward, expected.forward_steps);
        EXPECT_EQ(e.record.actions.back(), 0);
      }
    }
    EXPECT_TRUE(
        fs::exists(dir_ / agent / rollout::statsFileName(0, "val_seen")));
  }
  // without the training ground truth there are no statistics
  fs::remove(data::splitGroundTruthPath(dir_ / "data", "train"));
  EvalCommandOptions options;
  options.agent = "random";
  EXPECT_THAT([&] { run(options); },
              ::testing::Throws<std::runtime_error>(::testing::Property(
                  &std::exception::what, HasSubstr("need the ground truth of dataset.train_split"))));
}

TEST_F(EvalCommandsTest, TestSplitWritesLeaderboardPredictions) {
  const fs::path ckpt = writeCheckpoint(dir_ / "ckpt.2.pth", 1.0);
  EvalCommandOptions options;
  options.checkpoint = ckpt;
  options.out = dir_ / "out";
  options.splits = {"test"};
  options.episodes = 3;
  std::string printed;
  const EvalCommandResult r = run(options, &printed);
  ASSERT_EQ(r.reports.size(), 1u);
  EXPECT_FALSE(r.reports[0].scored);
  EXPECT_FALSE(fs::exists(dir_ / "out" / rollout::statsFileName(2, "test")));
  const auto predictions = rollout::readLeaderboardFile(
      dir_ / "out" / rollout::predictionsFileName(2, "test"));
  ASSERT_EQ(predictions.size(), 3u);  // --episodes 3
  const auto episodes = rollout::readEpisodesFile(
      dir_ / "out" / rollout::episodesFileName(2, "test"));
  for (const auto& [id, steps] : predictions) {
    const auto it = std::find_if(episodes.begin(), episodes.end(),
                                 [&](const rollout::EpisodeResult& e) {
                                   return e.record.episode_id == id;
                                 });
    ASSERT_NE(it, episodes.end());
    EXPECT_EQ(steps.size(), it->record.positions.size());
    EXPECT_EQ(steps.back().stop, it->record.called_stop);
  }
  EXPECT_THAT(printed, HasSubstr("ckpt 2 test: 3 episodes"));
  EXPECT_THAT(printed, HasSubstr("no goals (leaderboard predictions written)"));
}

// the test split holds val_unseen's episodes without goals, hidden/test/
// their goals and ground truth (RolloutTestWorld.h): scored from them, it
// scores as val_unseen does
TEST_F(EvalCommandsTest, TestSplitScoredFromHiddenGoalsKeepsItsPredictions) {
  const fs::path ckpt = writeCheckpoint(dir_ / "ckpt.2.pth", 1.0);
  EvalCommandOptions options;
  options.checkpoint = ckpt;
  options.out = dir_ / "out";
  options.splits = {"val_unseen", "test"};
  options.test_ground_truth = dir_ / "data" / "hidden";
  std::string printed;
  const EvalCommandResult r = run(options, &printed);
  ASSERT_EQ(r.reports.size(), 2u);
  EXPECT_TRUE(r.reports[1].scored);
  const rollout::SplitStats test =
      rollout::readStatsFile(dir_ / "out" / rollout::statsFileName(2, "test"));
  const rollout::SplitStats unseen = rollout::readStatsFile(
      dir_ / "out" / rollout::statsFileName(2, "val_unseen"));
  EXPECT_EQ(test.num_episodes, 5);
  EXPECT_EQ(rollout::metricsToJson(test.mean),
            rollout::metricsToJson(unseen.mean));
  // the leaderboard file as without the goals: every episode
  const auto predictions = rollout::readLeaderboardFile(
      dir_ / "out" / rollout::predictionsFileName(2, "test"));
  EXPECT_EQ(predictions.size(), 5u);
  EXPECT_FALSE(
      fs::exists(dir_ / "out" / rollout::predictionsFileName(2, "val_unseen")));
  EXPECT_THAT(printed,
              HasSubstr("test: scored from the hidden goals " +
                        data::hiddenGoalsPath(dir_ / "data", "test").string()));
  EXPECT_THAT(printed, HasSubstr("ckpt 2 test: 5 episodes"));
  EXPECT_THAT(printed, ::testing::Not(HasSubstr("no goals")));
}

TEST_F(EvalCommandsTest, HiddenGroundTruthErrorsNameTheFileAndEpisode) {
  EvalCommandOptions options;
  options.checkpoint = writeCheckpoint(dir_ / "ckpt.1.pth", 1.0);
  options.out = dir_ / "out";
  options.splits = {"val_unseen"};
  options.test_ground_truth = dir_ / "data" / "hidden";
  EXPECT_THAT(vln::test::errorOf([&] { run(options); }),
              HasSubstr("scores the split 'test', which is not evaluated "
                        "(add --split test)"));
  options.splits = {"test"};
  options.test_ground_truth = dir_ / "nowhere";
  EXPECT_THAT(vln::test::errorOf([&] { run(options); }),
              HasSubstr("eval --test-ground-truth: findHiddenFiles(): '" +
                        (dir_ / "nowhere").string() + "' does not exist"));
  // a ground truth that misses an episode of the split
  const fs::path gt = data::hiddenGroundTruthPath(dir_ / "data", "test");
  data::GroundTruth truth = data::readGroundTruth(gt);
  const int dropped = truth.rbegin()->first;
  truth.erase(dropped);
  data::writeGroundTruth(gt, truth);
  options.test_ground_truth = gt;
  const std::string error = vln::test::errorOf([&] { run(options); });
  EXPECT_THAT(error, HasSubstr("eval --test-ground-truth: "));
  EXPECT_THAT(error, HasSubstr(gt.string()));
  EXPECT_THAT(error, HasSubstr("episode " + std::to_string(dropped) +
                               " of split 'test' is missing"));
  // a malformed goals file
  vln::test::writeText(data::hiddenGoalsPath(dir_ / "data", "test"), "{");
  EXPECT_THAT(vln::test::errorOf([&] { run(options); }),
              HasSubstr("test_goals.json.gz"));
}

TEST_F(EvalCommandsTest, NavGraphComparisonAndPictures) {
  const fs::path ckpt = writeCheckpoint(dir_ / "ckpt.5.pth", 1.0);
  EvalCommandOptions options;
  options.checkpoint = ckpt;
  options.out = dir_ / "out";
  options.splits = {"val_seen"};
  options.navgraph = dir_ / "data" / "connectivity";
  options.maps = 2;
  options.videos = 1;
  std::string printed;
  const EvalCommandResult r = run(options, &printed);
  const GraphSplitStats g = readGraphStatsFile(dir_ / "out" / graphStatsFileName(5, "val_seen"));
  EXPECT_EQ(g.num_episodes, 5);
  ASSERT_TRUE(r.reports[0].graph.has_value());
  EXPECT_EQ(*r.reports[0].graph, g);
  // recomputed from the per-episode file with the same graph
  const data::NavGraph graph = data::readNavGraph(options.navgraph / "h5_connectivity.json");
  const auto episodes = rollout::readEpisodesFile(
      dir_ / "out" / rollout::episodesFileName(5, "val_seen"));
  const auto& w = rolloutTestWorld();
  const data::NavGraph floor = floorNavGraph(graph, w.scene->navmesh());
  std::vector<GraphEpisodeMetrics> metrics;
  for (size_t i = 0; i < episodes.size(); ++i)
    metrics.push_back(scoreOnNavGraph(graph, floor, episodes[i].record.positions,
                                      w.episodes[i].reference_path,
                                      episodes[i].record.episode_id));
  EXPECT_EQ(aggregateGraph(metrics), g);
  EXPECT_THAT(printed, HasSubstr("| nav-graph TL "));
  const fs::path pictures = dir_ / "out" / "pictures";
  EXPECT_TRUE(fs::exists(pictures / viz::mapFileName("ckpt_5_val_seen_", episodes[1].record.episode_id)));
  EXPECT_FALSE(fs::exists(pictures / viz::mapFileName("ckpt_5_val_seen_", episodes[2].record.episode_id)));
  EXPECT_EQ(viz::summarizeVideo(pictures / viz::videoFileName("ckpt_5_val_seen_", episodes[0].record.episode_id, "avi"))
                .frames,
            episodes[0].record.steps_taken + 1);
}

TEST_F(EvalCommandsTest, HtmlReportPerCheckpointAndSplit) {
  const fs::path ckpts = dir_ / "checkpoints";
  for (int i : {1, 2}) writeCheckpoint(ckpts / checkpointName(i), 1.0);
  EvalCommandOptions options;
  options.checkpoint = ckpts;
  options.out = dir_ / "out";
  options.report = dir_ / "report";
  options.report_episodes = 2;
  std::string printed;
  const EvalCommandResult r = run(options, &printed);
  ASSERT_EQ(r.reports.size(), 4u);
  // a page per checkpoint and split, and the index of them
  for (int i : {1, 2})
    for (const std::string split : {"val_seen", "val_unseen"}) {
      SCOPED_TRACE(std::to_string(i) + " " + split);
      const fs::path page =
          options.report / ("ckpt_" + std::to_string(i) + "_" + split) / "index.html";
      ASSERT_TRUE(fs::exists(page));
      const std::string html = vln::test::readText(page);
      const size_t at = html.find("const REPORT = ");
      const size_t end = html.find(";\n", at);
      const nlohmann::json data = nlohmann::json::parse(html.substr(at + 15, end - at - 15));
      EXPECT_EQ(data["episodes"].size(), 5u);
      ASSERT_EQ(data["details"].size(), 2u);
      // the CMA's attention over the split vocabulary's words, every step
      for (const auto& [id, detail] : data["details"].items()) {
        ASSERT_TRUE(detail["attention"].is_array()) << id;
        EXPECT_EQ(detail["attention"].size(), detail["actions"].size());
        EXPECT_EQ(detail["attention"][0].size(), detail["words"].size());
        EXPECT_NE(detail["words"][0].get<std::string>().front(), '#');
      }
      EXPECT_NEAR(data["summary"]["spl"].get<double>(),
                  rollout::readStatsFile(options.out / rollout::statsFileName(i, split)).mean.spl,
                  1e-9);
    }
  const std::string index = vln::test::readText(options.report / "index.html");
  EXPECT_THAT(index, HasSubstr("ckpt_2_val_unseen/index.html"));
  EXPECT_THAT(printed, HasSubstr("report: " + (options.report / "index.html").string()));
  // a bad count is named
  options.report_episodes = -1;
  EXPECT_THAT(vln::test::errorOf([&] { run(options); }), HasSubstr("--report-episodes"));
}

// Connectivity files hold viewpoints at camera height; matching happens on
// their floor waypoints and scoring on the viewpoints, so lifting every node
// by a camera height changes nothing on a single floor.
TEST(EvalNavGraphTest, CameraHeightViewpointsScoreLikeFloorNodes) {
  const auto& w = rolloutTestWorld();
  const data::NavGraph onFloor = rollout::test::referenceNavGraph(w);
  data::NavGraph lifted;
  for (int i = 0; i < onFloor.numNodes(); ++i)
    lifted.addNode(onFloor.node(i).id, onFloor.node(i).position + Vec3f(0.0f, 1.4f, 0.0f));
  for (const auto& [a, b] : onFloor.edges()) lifted.addEdge(onFloor.node(a).id, onFloor.node(b).id);
  const data::NavGraph floor = floorNavGraph(lifted, w.scene->navmesh());
  for (int i = 0; i < floor.numNodes(); ++i) {
    EXPECT_EQ(floor.node(i).id, lifted.node(i).id);
    EXPECT_LT((floor.node(i).position - onFloor.node(i).position).norm(), 0.1f);
  }
  EXPECT_EQ(floor.edges(), lifted.edges());
  int successes = 0;
  double steps = 0.0;
  for (size_t i = 0; i < w.episodes.size(); ++i) {
    const auto& e = w.episodes[i];
    const std::string id = std::to_string(e.episode_id);
    const GraphEpisodeMetrics expected =
        scoreContinuousPath(onFloor, w.followerPositions[i], e.reference_path, id);
    const GraphEpisodeMetrics got =
        scoreOnNavGraph(lifted, floor, w.followerPositions[i], e.reference_path, id);
    EXPECT_NEAR(got.path_length, expected.path_length, 1e-5);
    EXPECT_NEAR(got.distance_to_goal, expected.distance_to_goal, 1e-5);
    EXPECT_EQ(got.success, expected.success);
    EXPECT_NEAR(got.spl, expected.spl, 1e-6);
    EXPECT_EQ(got.trajectory_steps, expected.trajectory_steps);
    successes += got.success > 0.0;
    steps += got.trajectory_steps;
  }
  // non-trivial paths; the follower ends at the goal, but snapping to this
  // sparse graph can get stuck on the way (5 of 10 succeed)
  EXPECT_GE(successes, 3);
  EXPECT_GT(steps, 20.0);
  // matching camera-height nodes directly fails: they are 1.4 m up
  EXPECT_THROW(scoreContinuousPath(lifted, w.followerPositions[0], w.episodes[0].reference_path, "0"),
               std::invalid_argument);
}

TEST_F(EvalCommandsTest, BadInputIsNamed) {
  auto expectError = [&](const EvalCommandOptions& options, const std::string& what) {
    try {
      run(options);
      ADD_FAILURE() << "no error, expected: " << what;
    } catch (const std::exception& e) {
      EXPECT_THAT(e.what(), HasSubstr(what));
    }
  };
  EvalCommandOptions both;
  both.agent = "random";
  both.checkpoint = dir_ / "x.pth";
  expectError(both, "give either --checkpoint or --agent");
  EvalCommandOptions none;
  expectError(none, "give --checkpoint");
  EvalCommandOptions missing;
  missing.checkpoint = dir_ / "nope.pth";
  expectError(missing, "nope.pth' does not exist");
  EvalCommandOptions empty;
  fs::create_directories(dir_ / "empty");
  empty.checkpoint = dir_ / "empty";
  expectError(empty, "holds no ckpt.<i>.pth");
  EvalCommandOptions split;
  split.checkpoint = writeCheckpoint(dir_ / "ckpt.1.pth", 1.0);
  split.splits = {"val_nowhere"};
  expectError(split, "val_nowhere");
  // ensembles are of waypoint agents only
  EvalCommandOptions ensemble;
  ensemble.checkpoint = split.checkpoint;
  ensemble.ensemble = {split.checkpoint};
  expectError(ensemble, "eval --ensemble: only waypoint agents");
  EvalCommandOptions greedy;
  greedy.agent = "greedy";
  expectError(greedy,
              "--agent must be random, handcrafted or oracle, got 'greedy'");

  // a checkpoint of another architecture: every mismatched tensor listed
  models::ModelConfig wide = settings_.model;
  wide.hidden_size = 12;
  writePolicyCheckpoint(dir_ / "ckpt.9.pth", *models::makePolicy(wide));
  EvalCommandOptions mismatch;
  mismatch.checkpoint = dir_ / "ckpt.9.pth";
  try {
    run(mismatch);
    ADD_FAILURE() << "no error";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("ckpt.9.pth"));
    EXPECT_THAT(e.what(), HasSubstr("action_head.weight"));
    EXPECT_THAT(e.what(), HasSubstr("second_state_encoder"));
  }
}

// ---------------------------------------------------------------------------
// the oracle and observation dumps

TEST_F(EvalCommandsTest, OracleSucceedsEverywhereAndIsDumped) {
  const auto& w = rolloutTestWorld();
  EvalCommandOptions options;
  options.agent = "oracle";
  options.out = dir_ / "oracle";
  options.dump.dir = dir_ / "dump";
  options.dump.episodes = 2;
  std::string printed;
  const EvalCommandResult r = run(options, &printed);
  EXPECT_THAT(printed, HasSubstr("oracle: trainer.expert goal, stopping "
                                 "within task.follower_goal_radius 0.5 m"));
  ASSERT_EQ(r.reports.size(), 2u);
  for (const auto& report : r.reports) {
    SCOPED_TRACE(report.split);
    // the test world's ground truth is the same follower: SR 1
    EXPECT_EQ(report.stats.mean.success, 1.0);
    EXPECT_GT(report.stats.mean.spl, 0.8);
    EXPECT_THAT(printed, HasSubstr("ckpt 0 " + report.split + ": 5 episodes"));
  }
  // the first two episodes of each split, listed with the report's files
  const std::vector<std::pair<std::string, size_t>> splits = {
      {"val_seen", 0}, {"val_unseen", 5}};
  for (const auto& [split, first] : splits) {
    EXPECT_EQ(vln::test::countEntries(dir_ / "dump" / split), 2) << split;
    for (size_t i = first; i < first + 2; ++i) {
      const fs::path folder =
          dir_ / "dump" / split / std::to_string(w.episodes[i].episode_id);
      EXPECT_TRUE(fs::exists(folder / "episode.json")) << folder;
      const auto& files = r.reports[first == 0 ? 0 : 1].files;
      EXPECT_NE(std::find(files.begin(), files.end(), folder), files.end());
      EXPECT_EQ(common::readJsonFile(folder / "episode.json")["agent"],
                "oracle");
    }
  }
}

TEST_F(EvalCommandsTest, AnyAgentIsDumpedByIdWithPictures) {
  const auto& w = rolloutTestWorld();
  EvalCommandOptions options;
  options.checkpoint = writeCheckpoint(dir_ / "ckpt.3.pth", 1.0);
  options.out = dir_ / "out";
  options.splits = {"val_unseen"};
  options.maps = 1;
  options.dump.dir = dir_ / "dump";
  options.dump.ids = std::to_string(w.episodes[7].episode_id) + ", " +
                     std::to_string(w.episodes[9].episode_id);
  options.dump.format = "jpg";
  const EvalCommandResult r = run(options);
  const fs::path split = dir_ / "dump" / "val_unseen";
  EXPECT_EQ(vln::test::countEntries(split), 2);
  const fs::path folder = split / std::to_string(w.episodes[7].episode_id);
  EXPECT_TRUE(fs::exists(folder / "rgb" / "000000.jpg"));
  EXPECT_EQ(common::readJsonFile(folder / "episode.json")["agent"],
            "ckpt.3.pth");
  // the pictures were drawn beside the dump
  EXPECT_EQ(vln::test::countEntries(dir_ / "out" / "pictures"), 1);
  // a second dump into the same folder is refused before anything runs
  EXPECT_THAT(vln::test::errorOf([&] { run(options); }),
              HasSubstr(folder.string() + "' exists already"));
}

TEST_F(EvalCommandsTest, OracleRefusesSplitsWithoutGoals) {
  EvalCommandOptions options;
  options.agent = "oracle";
  options.splits = {"val_seen", "test"};
  options.out = dir_ / "out";
  EXPECT_THAT(vln::test::errorOf([&] { run(options); }),
              HasSubstr("eval --agent oracle: split 'test' has no goals"));
  EXPECT_FALSE(
      fs::exists(dir_ / "out" / rollout::statsFileName(0, "val_seen")));
  options.checkpoint = dir_ / "x.pth";
  EXPECT_THAT(vln::test::errorOf([&] { run(options); }),
              HasSubstr("give either --checkpoint or --agent"));
}

TEST_F(EvalCommandsTest, BadDumpFlagsAreNamed) {
  const auto errorOf = [&](const DumpOptions& dump) {
    EvalCommandOptions options;
    options.agent = "oracle";
    options.out = dir_ / "out";
    options.dump = dump;
    return vln::test::errorOf([&] { run(options); });
  };
  DumpOptions none;
  none.episodes = 2;
  EXPECT_THAT(errorOf(none), HasSubstr("--dump-episodes needs --dump DIR"));
  none = {};
  none.ids = "100";
  EXPECT_THAT(errorOf(none), HasSubstr("--dump-ids needs --dump DIR"));
  none = {};
  none.format = "jpg";
  EXPECT_THAT(errorOf(none), HasSubstr("--dump-format needs --dump DIR"));

  DumpOptions bad;
  bad.dir = dir_ / "dump";
  bad.episodes = 0;
  EXPECT_THAT(errorOf(bad), HasSubstr("--dump-episodes must be >= 1, got 0"));
  bad.episodes = 1;
  bad.ids = "100";
  EXPECT_THAT(errorOf(bad),
              HasSubstr("give --dump-episodes or --dump-ids, not both"));
  bad.episodes.reset();
  bad.ids = "100,x";
  EXPECT_THAT(errorOf(bad), HasSubstr("--dump-ids: 'x' is not an episode id"));
  bad.ids = "99999";
  EXPECT_THAT(errorOf(bad),
              HasSubstr("--dump-ids: episode 99999 is in none of the "
                        "evaluated splits (val_seen, val_unseen"));
  bad.ids.clear();
  bad.format = "bmp";
  EXPECT_THAT(errorOf(bad),
              HasSubstr("--dump-format must be png or jpg, got 'bmp'"));
  EXPECT_FALSE(fs::exists(dir_ / "dump"));

  // a directory of checkpoints would dump every one into the same folders
  const fs::path ckpts = dir_ / "checkpoints";
  for (int i : {1, 2}) writeCheckpoint(ckpts / checkpointName(i), 1.0);
  EvalCommandOptions directory;
  directory.checkpoint = ckpts;
  directory.dump.dir = dir_ / "dump";
  EXPECT_THAT(vln::test::errorOf([&] { run(directory); }),
              HasSubstr("--dump takes one checkpoint, export or agent, not a "
                        "directory of 2 checkpoints"));
}

TEST(EvalTablesCommandTest, WritesMarkdownAndLatexFromResultFiles) {
  vln::test::TempDir dir;
  TablesCommandOptions options;
  options.runs = vln::test::testDataPath() / "eval" / "results";
  options.out = dir / "docs" / "results.md";
  std::ostringstream out;
  EXPECT_EQ(runTablesCommand(options, out), 0);
  const std::string md = common::readFile(dir / "docs" / "results.md");
  const std::string tex = common::readFile(dir / "docs" / "results.tex");
  EXPECT_THAT(out.str(), HasSubstr("results.md and "));
  EXPECT_THAT(md, HasSubstr("eval tables --runs"));
  // every table, the fixture runs cited, the same content in LaTeX
  for (const auto& table : buildTables(options.runs)) {
    EXPECT_THAT(md, HasSubstr(renderMarkdown(table)));
    EXPECT_THAT(tex, HasSubstr(renderLatex(table)));
  }
  EXPECT_THAT(md, HasSubstr("configs/baseline_random.yaml"));
  options.out = dir / "results.tex";
  EXPECT_THROW(runTablesCommand(options, out), std::invalid_argument);
  options.runs = dir / "nowhere";
  options.out = dir / "x.md";
  EXPECT_THROW(runTablesCommand(options, out), std::runtime_error);
}

TEST(EvalTablesCommandTest, ClaimedOnlyDropsRowsNoRunClaims) {
  vln::test::TempDir dir;
  TablesCommandOptions options;
  options.runs = vln::test::testDataPath() / "eval" / "seeds";
  options.out = dir / "table.md";
  options.claimed_only = true;
  std::ostringstream out;
  EXPECT_EQ(runTablesCommand(options, out), 0);
  EXPECT_THAT(out.str(), HasSubstr("(2 tables, 5 rows of ours)"));
  const std::string md = common::readFile(dir / "table.md");
  EXPECT_THAT(md, HasSubstr("--claimed-only"));
  EXPECT_THAT(md, ::testing::Not(HasSubstr("missing (no run)")));
  EXPECT_THAT(md, ::testing::Not(HasSubstr("### Table 3")));
  EXPECT_THAT(md, HasSubstr("0.20 ± 0.25"));
}

TEST(EvalCompareCommandTest, WritesTheFindingsWithVerdicts) {
  vln::test::TempDir dir;
  CompareCommandOptions options;
  options.runs = vln::test::testDataPath() / "eval" / "seeds";
  options.out = dir / "findings.md";
  std::ostringstream out;
  EXPECT_EQ(runCompareCommand(options, out), 0);
  EXPECT_THAT(out.str(), HasSubstr("findings.md ("));
  EXPECT_THAT(out.str(), HasSubstr("1 hold, 1 do not hold"));
  const std::string md = common::readFile(dir / "findings.md");
  EXPECT_THAT(md, HasSubstr("<!-- Generated by `eval compare --runs "));
  EXPECT_THAT(md, HasSubstr("| holds |"));
  options.runs = dir / "nowhere";
  EXPECT_THROW(runCompareCommand(options, out), std::runtime_error);
}

// eval curve on a run folder holding a metrics.jsonl of two validations
TEST(EvalCurveCommandTest, DrawsTheRunsLearningCurve) {
  vln::test::TempDir dir;
  const fs::path run = dir / "runs" / "cma" / "seed1";
  vln::test::writeText(
      run / "metrics.jsonl",
      R"({"type":"start","time":100.0,"resumed":false,"checkpoint":-1,"updates":0,"setup_seconds":0.0}
{"type":"eval","time":160.0,"split":"val_unseen","checkpoint":0,"updates":40,"success":0.1,"spl":0.05}
{"type":"eval","time":220.0,"split":"val_unseen","checkpoint":1,"updates":80,"success":0.2,"spl":0.15}
)");
  CurveCommandOptions options;
  options.run = run.string() + "/";
  options.out = dir / "out" / "learning_curve.png";
  std::ostringstream out;
  EXPECT_EQ(runCurveCommand(options, out), 0);
  EXPECT_EQ(out.str(), "wrote " + options.out.string() +
                           " (2 validations of val_unseen; best SPL 0.150 (SR "
                           "0.200) at ckpt 1, 80 updates, 2.0 min)\n");
  EXPECT_EQ(common::readFile(options.out).substr(0, 4), "\x89PNG");

  // another split, a run without metrics
  options.split = "val_seen";
  EXPECT_THAT(vln::test::errorOf([&] { runCurveCommand(options, out); }),
              HasSubstr("no \"eval\" record of split 'val_seen'"));
  options.run = dir / "nowhere";
  EXPECT_THAT(
      vln::test::errorOf([&] { runCurveCommand(options, out); }),
      HasSubstr("eval curve: '" + (dir / "nowhere" / "metrics.jsonl").string() +
                "' does not exist"));
}

}  // namespace
}  // namespace vln::eval
