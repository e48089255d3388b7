// ScriptedWaypointModel runs a models::exportWaypointPolicy() archive inside
// a WaypointAgent: the agent takes the same actions, candidates and
// decisions as over the modules that were exported (depth-only baseline
// candidates walked; the archive's own predictor teleported; a goal-match
// policy given each episode's goal labels), and archives it cannot run are
// refused with the file named.

#include "rollout/ScriptedWaypointModel.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "models/Export.h"
#include "models/WaypointExport.h"
#include "rollout/Evaluator.h"
#include "rollout/RolloutTestPolicy.h"
#include "rollout/RolloutTestWorld.h"
#include "rollout/WaypointAgent.h"
#include "support/TestPaths.h"
#include "world/ViewLabels.h"

namespace vln::rollout {
namespace {

using test::rolloutTestWorld;
using ::testing::HasSubstr;

constexpr int kViews = 12;

int64_t flat(const models::FeatureShape& s) { return s[0] * s[1] * s[2]; }

struct Exported {
  std::shared_ptr<models::WaypointCmaPolicyImpl> policy;
  models::ObservationEncoder encoder{nullptr};
  models::WaypointPredictor predictor{nullptr};
  WaypointAgentConfig config;
  sim::PanoramaConfig panorama;
};

// a seeded random agent (with a small predictor when asked; with
// model.goal_match over random semantic heads of the view labels' layout)
Exported tinyAgent(uint64_t seed, bool withPredictor, bool goalMatch = false) {
  torch::manual_seed(seed);
  Exported t;
  models::ModelConfig model = test::tinyModel(models::PolicyType::kCma);
  if (goalMatch) {
    model.rgb_semantic_outputs = static_cast<int>(world::viewLabelSize());
    model.goal_match = true;
  }
  t.policy = std::make_shared<models::WaypointCmaPolicyImpl>(
      model, kViews, flat(models::rgbFeatureShape(model)),
      flat(models::depthFeatureShape(model)));
  t.encoder = models::ObservationEncoder(model);
  if (withPredictor) {
    models::WaypointPredictorConfig p;
    p.hidden_size = 16;
    p.heads = 2;
    p.ff_size = 24;
    p.layers = 1;
    t.predictor = models::makeWaypointPredictor(model, p, kViews);
    t.predictor->eval();
  }
  t.config.candidates = withPredictor ? "predictor" : "depth_baseline";
  t.panorama.rgb = {32, 32, 90.0f, 1.25f};
  t.panorama.depth.camera = {32, 32, 90.0f, 1.25f};
  return t;
}

EvaluationResult run(WaypointAgent& agent,
                     const std::vector<data::Episode>& episodes) {
  const auto& w = rolloutTestWorld();
  sim::TaskConfig task = w.task;
  task.max_episode_steps = 300;
  VectorEnv envs(2, w.sim, task, std::make_shared<SceneCache>(w.sim), 2);
  return evaluateEpisodes(agent, envs, episodes, nullptr, EvalConfig{});
}

void expectSameEpisodes(const EvaluationResult& a, const EvaluationResult& b) {
  ASSERT_EQ(a.episodes.size(), b.episodes.size());
  size_t decisions = 0;
  for (size_t i = 0; i < a.episodes.size(); ++i) {
    const EpisodeRecord& x = a.episodes[i].record;
    const EpisodeRecord& y = b.episodes[i].record;
    EXPECT_EQ(x.actions, y.actions) << "episode " << i;
    ASSERT_EQ(x.waypoint_choices.size(), y.waypoint_choices.size());
    for (size_t k = 0; k < x.waypoint_choices.size(); ++k) {
      EXPECT_EQ(x.waypoint_choices[k].chosen, y.waypoint_choices[k].chosen);
      ASSERT_EQ(x.waypoint_choices[k].candidates.size(),
                y.waypoint_choices[k].candidates.size());
      for (size_t j = 0; j < x.waypoint_choices[k].candidates.size(); ++j)
        EXPECT_LT((x.waypoint_choices[k].candidates[j] -
                   y.waypoint_choices[k].candidates[j])
                      .norm(),
                  1e-4f);
    }
    decisions += x.waypoint_choices.size();
  }
  EXPECT_GT(decisions, a.episodes.size());  // more than STOP at once
}

TEST(ScriptedWaypointModelTest, ActsAsTheModulesItExports) {
  const auto& w = rolloutTestWorld();
  for (const bool withPredictor : {false, true}) {
    SCOPED_TRACE(withPredictor ? "predictor, teleported"
                               : "depth baseline, walked");
    Exported t = tinyAgent(withPredictor ? 5 : 4, withPredictor);
    if (withPredictor) t.config.execution = waypoint::Execution::kTeleport;
    CandidateNms nms;
    nms.max_candidates = 4;
    vln::test::TempDir dir;
    const auto file = dir / "agent.pt";
    models::ExportedPredictor exported;
    exported.predictor = withPredictor ? t.predictor.get() : nullptr;
    exported.max_candidates = nms.max_candidates;
    models::exportWaypointPolicy(*t.policy, t.encoder.get(), file, exported);

    WaypointAgent native(t.policy, t.encoder, t.predictor, nms, t.config,
                         t.panorama, rolloutTestWorld().sim.agent, 2,
                         /*sampleActions=*/true, /*seed=*/7, 200);
    auto model = std::make_unique<ScriptedWaypointModel>(file, 200);
    EXPECT_EQ(model->numViews(), kViews);
    EXPECT_EQ(model->proposes(), withPredictor);
    WaypointAgent scripted(std::move(model), t.config, t.panorama,
                           rolloutTestWorld().sim.agent, 2,
                           /*sampleActions=*/true, /*seed=*/7);
    expectSameEpisodes(run(native, w.episodes), run(scripted, w.episodes));
  }
}

// the archive of a goal-match policy is given each episode's goal labels
// as the policy is (batchGoalLabels() of its instruction's text), so it
// takes the same decisions; the episodes name different goals, one in four
// nothing, and two environments run them side by side
TEST(ScriptedWaypointModelTest, GoalMatchActsAsTheModulesItExports) {
  Exported t = tinyAgent(8, /*withPredictor=*/false, /*goalMatch=*/true);
  {
    // the STOP key's goal term made large enough to decide
    torch::NoGradGuard noGrad;
    t.policy->goal_stop->weight.mul_(10.0);
  }
  const char* texts[] = {"Walk past the white sofa, then stop.",
                         "Turn left. Go left, then stop in the lounge.",
                         "Wait by the table",
                         "Go straight. Stop at the red one."};
  std::vector<data::Episode> named = rolloutTestWorld().episodes;
  std::vector<data::Episode> unnamed = named;
  for (size_t i = 0; i < named.size(); ++i) {
    named[i].instruction.instruction_text = texts[i % 4];
    unnamed[i].instruction.instruction_text = texts[3];
  }
  vln::test::TempDir dir;
  const auto file = dir / "agent.pt";
  models::exportWaypointPolicy(*t.policy, t.encoder.get(), file);

  auto nativeRun = [&](const std::vector<data::Episode>& episodes) {
    WaypointAgent native(t.policy, t.encoder, t.predictor, CandidateNms{},
                         t.config, t.panorama, rolloutTestWorld().sim.agent, 2,
                         /*sampleActions=*/true, /*seed=*/9, 200);
    return run(native, episodes);
  };
  WaypointAgent scripted(std::make_unique<ScriptedWaypointModel>(file, 200),
                         t.config, t.panorama, rolloutTestWorld().sim.agent, 2,
                         /*sampleActions=*/true, /*seed=*/9);
  const EvaluationResult expected = nativeRun(named);
  expectSameEpisodes(expected, run(scripted, named));
  // the labels decide here: naming nothing, some episode goes otherwise
  const EvaluationResult plain = nativeRun(unnamed);
  bool differs = false;
  for (size_t i = 0; i < plain.episodes.size(); ++i)
    differs = differs || plain.episodes[i].record.actions !=
                             expected.episodes[i].record.actions;
  EXPECT_TRUE(differs) << "the goal labels changed no decision";
}

TEST(ScriptedWaypointModelTest, ProposesWhatThePredictorsSuppressionKeeps) {
  Exported t = tinyAgent(6, /*withPredictor=*/true);
  vln::test::TempDir dir;
  models::ExportedPredictor exported{t.predictor.get(), 5, 7, 5, 0.0};
  models::exportWaypointPolicy(*t.policy, t.encoder.get(), dir / "agent.pt",
                               exported);
  ScriptedWaypointModel scripted(dir / "agent.pt", 200);
  NativeWaypointModel native(t.policy, t.encoder, t.predictor, CandidateNms{},
                             200);
  const torch::Tensor rgb =
      torch::randint(0, 256, {3, kViews, 32, 32, 3}, torch::kUInt8);
  const torch::Tensor depth = torch::rand({3, kViews, 32, 32, 1});
  const PanoramaFeatures a = native.encode(rgb, depth);
  const PanoramaFeatures b = scripted.encode(rgb, depth);
  EXPECT_TRUE(torch::allclose(a.rgb, b.rgb, 1e-4, 1e-5));
  EXPECT_TRUE(torch::allclose(a.depth, b.depth, 1e-4, 1e-5));
  const auto x = native.propose(a);
  const auto y = scripted.propose(a);
  ASSERT_EQ(x.size(), 3u);
  ASSERT_EQ(y.size(), 3u);
  for (size_t i = 0; i < x.size(); ++i) {
    ASSERT_EQ(x[i].size(), y[i].size());
    EXPECT_FALSE(x[i].empty());
    for (size_t j = 0; j < x[i].size(); ++j) {
      EXPECT_EQ(x[i][j].heading_bin, y[i][j].heading_bin);
      EXPECT_EQ(x[i][j].distance_bin, y[i][j].distance_bin);
      EXPECT_FLOAT_EQ(x[i][j].heading, y[i][j].heading);
      EXPECT_NEAR(x[i][j].score, y[i][j].score, 1e-5);
    }
  }
}

TEST(ScriptedWaypointModelTest, ArchivesItCannotRunAreNamed) {
  vln::test::TempDir dir;
  EXPECT_THAT([&] { ScriptedWaypointModel m(dir / "missing.pt", 200); },
              ::testing::Throws<std::runtime_error>(::testing::Property(
                  &std::exception::what,
                  HasSubstr("missing.pt' does not exist"))));
  // a low-level policy's archive
  auto low = test::tinyAgentModel(models::PolicyType::kCma, 2);
  models::exportPolicy(*low.policy, low.encoder.get(), dir / "low.pt");
  EXPECT_THAT([&] { ScriptedWaypointModel m(dir / "low.pt", 200); },
              ::testing::Throws<std::invalid_argument>(::testing::Property(
                  &std::exception::what,
                  HasSubstr("low.pt' is not a waypoint policy export"))));
  // without the encoders it takes features, not panoramas
  Exported t = tinyAgent(7, /*withPredictor=*/false);
  models::exportWaypointPolicy(*t.policy, nullptr, dir / "features.pt");
  EXPECT_THAT([&] { ScriptedWaypointModel m(dir / "features.pt", 200); },
              ::testing::Throws<std::invalid_argument>(::testing::Property(
                  &std::exception::what,
                  HasSubstr("exported without its RGB encoder"))));
  // a goal match over labels other than world::goalLabels()'
  models::ModelConfig seven = test::tinyModel(models::PolicyType::kCma);
  seven.rgb_semantic_outputs = 7;
  seven.goal_match = true;
  models::WaypointCmaPolicyImpl sevenLabels(
      seven, kViews, 7, flat(models::depthFeatureShape(seven)));
  models::ObservationEncoder sevenEncoder(seven);
  models::exportWaypointPolicy(sevenLabels, sevenEncoder.get(),
                               dir / "seven.pt");
  EXPECT_THAT([&] { ScriptedWaypointModel m(dir / "seven.pt", 200); },
              ::testing::Throws<std::invalid_argument>(::testing::Property(
                  &std::exception::what,
                  HasSubstr("seven.pt' matches the goal over "
                            "model.rgb_semantic_outputs 7 labels"))));
  // without the predictor it cannot be asked for candidates
  models::exportWaypointPolicy(*t.policy, t.encoder.get(), dir / "bare.pt");
  auto agentOverBare = [&] {
    WaypointAgent a(std::make_unique<ScriptedWaypointModel>(dir / "bare.pt",
                                                            200),
                    t.config, t.panorama, rolloutTestWorld().sim.agent, 1,
                    false, 0);
  };
  t.config.candidates = "predictor";
  EXPECT_THAT(
      agentOverBare,
      ::testing::Throws<std::invalid_argument>(::testing::Property(
          &std::exception::what,
          HasSubstr("waypoint_agent.candidates is predictor"))));
  // views other than the archive's
  t.config.candidates = "depth_baseline";
  t.panorama.num_views = 6;
  EXPECT_THAT(
      agentOverBare,
      ::testing::Throws<std::invalid_argument>(::testing::Property(
          &std::exception::what, HasSubstr("reads 12 views"))));
}

}  // namespace
}  // namespace vln::rollout
