// The baseline agents as evaluation Agents: statistics from a training
// ground truth, per-episode seeding (results independent of batching), and
// the hand-crafted agent's turn-then-walk-then-stop behaviour in the house.

#include "eval/BaselineAgents.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <set>

#include "rollout/Evaluator.h"
#include "rollout/RolloutTestWorld.h"

namespace vln::eval {
namespace {

using rollout::test::rolloutTestWorld;
using ::testing::HasSubstr;

data::GroundTruthPath path(std::vector<Vec3f> locations, std::vector<int> codes) {
  data::GroundTruthPath p;
  p.locations = std::move(locations);
  for (int c : codes) p.actions.push_back(sim::actionFromInt(c));
  return p;
}

TEST(BaselineAgentsTest, StatisticsComeFromTheGroundTruth) {
  // two hand-made paths: 3 + 4 = 7 m long in total, 10 actions
  data::GroundTruth gt;
  gt[1] = path({{0, 0, 0}, {0, 0, -1}, {0, 0, -3}}, {1, 1, 2, 0});             // 3 m
  gt[2] = path({{1, 0, 0}, {1, 0, 4}}, {3, 3, 1, 1, 1, 0});                    // 4 m
  const BaselineStatistics s = baselineStatistics(gt, sim::AgentConfig{});
  EXPECT_EQ(s.num_paths, 2);
  EXPECT_DOUBLE_EQ(s.mean_path_length, 3.5);
  EXPECT_EQ(s.forward_steps, 14);  // 3.5 m / 0.25 m
  EXPECT_DOUBLE_EQ(s.distribution[0], 2.0 / 10.0);
  EXPECT_DOUBLE_EQ(s.distribution[1], 5.0 / 10.0);
  EXPECT_DOUBLE_EQ(s.distribution[2], 1.0 / 10.0);
  EXPECT_DOUBLE_EQ(s.distribution[3], 2.0 / 10.0);
  EXPECT_EQ(s.max_turns, 24);  // 15 degree turns
  // RxR-Habitat's agent: 30 degree turns, the same forward step
  sim::AgentConfig rxr;
  rxr.turn_angle = 30.0f;
  EXPECT_EQ(baselineStatistics(gt, rxr).max_turns, 12);
  sim::AgentConfig longSteps;
  longSteps.forward_step_size = 0.5f;
  EXPECT_EQ(baselineStatistics(gt, longSteps).forward_steps, 7);

  // the house's follower ground truth: forward steps of about 0.25 m each
  const auto& w = rolloutTestWorld();
  const BaselineStatistics h = baselineStatistics(w.groundTruth, sim::AgentConfig{});
  int forward = 0, total = 0;
  for (const auto& [id, p] : w.groundTruth) {
    forward += p.forward_steps;
    total += static_cast<int>(p.actions.size());
  }
  EXPECT_NEAR(h.distribution[1], static_cast<double>(forward) / total, 1e-12);
  EXPECT_NEAR(h.forward_steps, static_cast<double>(forward) / w.groundTruth.size(), 1.0);
}

TEST(BaselineAgentsTest, BadGroundTruthIsNamed) {
  EXPECT_THAT([] { baselineStatistics({}, sim::AgentConfig{}, "train_gt.json.gz"); },
              ::testing::Throws<std::invalid_argument>(::testing::Property(
                  &std::exception::what, HasSubstr("train_gt.json.gz has no ground-truth paths"))));
  data::GroundTruth empty;
  empty[7] = path({}, {0});
  EXPECT_THAT([&] { baselineStatistics(empty, sim::AgentConfig{}, "gt.json"); },
              ::testing::Throws<std::invalid_argument>(::testing::Property(
                  &std::exception::what, HasSubstr("gt.json: episode 7: field 'locations' is empty"))));
  data::GroundTruth noActions;
  noActions[3] = path({{0, 0, 0}}, {});
  EXPECT_THAT([&] { baselineStatistics(noActions, sim::AgentConfig{}, "gt.json"); },
              ::testing::Throws<std::invalid_argument>(
                  ::testing::Property(&std::exception::what, HasSubstr("gt.json: "))));
  EXPECT_THROW(BaselineAgentAdapter("greedy", BaselineStatistics{}, 2, 0), std::invalid_argument);
}

TEST(BaselineAgentsTest, HandcraftedTurnsWalksAndStopsInTheHouse) {
  const auto& w = rolloutTestWorld();
  BaselineStatistics stats;
  stats.forward_steps = 6;
  BaselineAgentAdapter agent("handcrafted", stats, 3, /*seed=*/4);
  EXPECT_FALSE(agent.needsObservations());
  auto cache = std::make_shared<rollout::SceneCache>(w.sim);
  rollout::VectorEnv envs(3, w.sim, w.task, cache, 2);
  rollout::EvalConfig config;
  const rollout::EvaluationResult r =
      rollout::evaluateEpisodes(agent, envs, w.episodes, nullptr, config);
  std::set<int> turnCounts;
  for (size_t i = 0; i < w.episodes.size(); ++i) {
    const auto& rec = r.episodes[i].record;
    // k right turns, 6 forward, STOP
    int turns = 0;
    while (rec.actions[static_cast<size_t>(turns)] == 3) ++turns;
    EXPECT_LE(turns, kHandcraftedMaxTurns);
    ASSERT_EQ(rec.actions.size(), static_cast<size_t>(turns + 6 + 1));
    for (int k = 0; k < 6; ++k) EXPECT_EQ(rec.actions[static_cast<size_t>(turns + k)], 1);
    EXPECT_EQ(rec.actions.back(), 0);
    EXPECT_TRUE(rec.called_stop);
    // each turn is 15 degrees to the right
    EXPECT_NEAR(wrapAngle(rec.headings[static_cast<size_t>(turns)] - rec.headings[0] +
                          degToRad(15.0f) * static_cast<float>(turns)),
                0.0f, 1e-4f);
    EXPECT_LE(r.episodes[i].metrics.path_length, 6 * 0.25 + 1e-4);
    // the turns drawn for this episode id, whatever environment ran it
    HandcraftedAgent alone(6, kHandcraftedMaxTurns, 4);
    alone.reset(std::to_string(w.episodes[i].episode_id));
    EXPECT_EQ(alone.turns(), turns);
    turnCounts.insert(turns);
  }
  EXPECT_GT(turnCounts.size(), 3u);  // headings really are random
}

TEST(BaselineAgentsTest, RandomAgentFollowsItsDistribution) {
  BaselineStatistics stats;
  stats.distribution = {0.0, 0.5, 0.5, 0.0};  // never stops, never turns right
  BaselineAgentAdapter agent("random", stats, 2, 1);
  data::Episode a, b;
  a.episode_id = 1;
  b.episode_id = 2;
  agent.reset(0, a);
  agent.reset(1, b);
  const auto& w = rolloutTestWorld();
  rollout::VectorEnv envs(2, w.sim, w.task,
                          std::make_shared<rollout::SceneCache>(w.sim), 1);
  const std::vector<int> active = {0, 1};
  int forward = 0;
  for (int t = 0; t < 500; ++t)
    for (sim::Action x : agent.act(envs, active)) {
      ASSERT_TRUE(x == sim::Action::kMoveForward || x == sim::Action::kTurnLeft);
      forward += x == sim::Action::kMoveForward;
    }
  EXPECT_NEAR(forward / 1000.0, 0.5, 0.06);  // 4 sigma of a binomial(1000, 0.5)

  // the same episode in another environment draws the same actions
  BaselineAgentAdapter other("random", stats, 2, 1);
  other.reset(1, a);
  BaselineAgentAdapter first("random", stats, 2, 1);
  first.reset(0, a);
  for (int t = 0; t < 50; ++t) {
    const std::vector<int> one = {1}, zero = {0};
    EXPECT_EQ(other.act(envs, one), first.act(envs, zero));
  }
  EXPECT_THAT([&] { BaselineAgentAdapter fresh("random", stats, 1, 0);
                    const std::vector<int> e = {0};
                    fresh.act(envs, e); },
              ::testing::Throws<std::invalid_argument>(::testing::Property(
                  &std::exception::what, HasSubstr("environment 0 was never reset"))));
}

}  // namespace
}  // namespace vln::eval
