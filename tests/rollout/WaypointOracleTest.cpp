// The oracle of src/rollout/WaypointOracle.cpp: the waypoint follower on a
// corridor (goal vs reference-path semantics), and OracleAgent evaluated on
// the small generated house, where it must reproduce the shortest-path
// follower's ground truth action for action (and so succeed on every
// episode), whatever the number of environments; episodes without goals
// are refused.

#include "rollout/WaypointOracle.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "rollout/Evaluator.h"
#include "rollout/RolloutTestWorld.h"
#include "sim/SimTestScenes.h"
#include "sim/SimTestSuites.h"
#include "support/TestUtil.h"

namespace vln::rollout {
namespace {

using test::rolloutTestWorld;
using ::testing::HasSubstr;

TEST(OracleModeTest, ParsesTrainerExpertValues) {
  EXPECT_EQ(parseOracleMode("goal", "x"), OracleMode::kGoal);
  EXPECT_EQ(parseOracleMode("reference_path", "x"), OracleMode::kReferencePath);
  EXPECT_EQ(oracleModeName(OracleMode::kReferencePath), "reference_path");
  EXPECT_THAT(vln::test::errorOf([] { parseOracleMode("nearest", "--flag"); }),
              HasSubstr("--flag: unknown expert 'nearest'"));
}

// A 12 m x 2 m corridor along +X.
sim::TriangleMesh corridor() {
  sim::TriangleMesh m;
  vln::test::addWalledFloor(m, 12, 2);
  return m;
}

class WaypointOracleTest : public vln::test::NavMeshSuite<corridor> {
 protected:
  // waypoints (1, 1), (6, 1), (9, 1); goal (9, 1)
  data::Episode episode() const {
    data::Episode e;
    e.episode_id = 7;
    for (float x : {1.0f, 6.0f, 9.0f})
      e.reference_path.push_back(standing(x, 1.0f, 0.0f).position);
    e.start_position = e.reference_path.front();
    e.goals.push_back({e.reference_path.back(), 3.0f});
    return e;
  }
  // the oracle's actions from `state` until it STOPs (at most 40), and the
  // waypoint it headed for at each
  std::vector<sim::Action> rollout(
      OracleMode mode, sim::AgentState state,
      std::vector<int>* waypoints = nullptr) const {
    const sim::AgentConfig agent;
    WaypointOracle oracle(navmesh(), agent, 0.5f,
                          oracleWaypoints(episode(), mode));
    std::vector<sim::Action> actions;
    while (actions.size() < 40) {
      actions.push_back(oracle.next(state));
      if (waypoints) waypoints->push_back(oracle.waypoint());
      if (actions.back() == sim::Action::kStop) break;
      (void)sim::applyAction(navmesh(), agent, state, actions.back());
    }
    return actions;
  }
};

// Drifted past waypoint (6, 1) to x = 7.9, facing +X: the goal oracle goes
// on (1.1 m in 0.25 m steps, STOP within 0.5 m); the reference-path oracle
// turns back to the waypoint first, then heads for the last one.
TEST_F(WaypointOracleTest, GoalGoesOnWhereTheReferencePathTurnsBack) {
  using sim::Action;
  const sim::AgentState drifted = standing(7.9f, 1.0f, -kPi / 2);
  EXPECT_EQ(rollout(OracleMode::kGoal, drifted),
            (std::vector<Action>{Action::kMoveForward, Action::kMoveForward,
                                 Action::kMoveForward, Action::kStop}));
  std::vector<int> waypoints;
  const std::vector<Action> back =
      rollout(OracleMode::kReferencePath, drifted, &waypoints);
  ASSERT_GT(back.size(), 4u);
  EXPECT_TRUE(back.front() == Action::kTurnLeft ||
              back.front() == Action::kTurnRight);
  EXPECT_EQ(back.back(), Action::kStop);
  EXPECT_EQ(waypoints.front(), 1);
  EXPECT_EQ(waypoints.back(), 2);
  EXPECT_TRUE(std::is_sorted(waypoints.begin(), waypoints.end()));
}

TEST_F(WaypointOracleTest, EpisodesWithoutWaypointsAreRefused) {
  data::Episode test = episode();
  test.goals.clear();
  test.reference_path.clear();
  EXPECT_THAT(
      vln::test::errorOf([&] { oracleWaypoints(test, OracleMode::kGoal); }),
      HasSubstr("episode 7: no goal for the oracle"));
  EXPECT_THAT(vln::test::errorOf(
                  [&] { oracleWaypoints(test, OracleMode::kReferencePath); }),
              HasSubstr("episode 7: no reference path"));
  EXPECT_THAT(vln::test::errorOf([&] {
                WaypointOracle(navmesh(), sim::AgentConfig{}, 0.5f, {});
              }),
              HasSubstr("at least one waypoint"));
}

// evaluateEpisodes() of the oracle on the house's episodes
EvaluationResult evaluateOracle(OracleMode mode, int numEnvs) {
  const auto& w = rolloutTestWorld();
  OracleAgent agent(w.sim.agent, w.task.follower_goal_radius, mode, numEnvs);
  VectorEnv envs(numEnvs, w.sim, w.task, std::make_shared<SceneCache>(w.sim),
                 2);
  return evaluateEpisodes(agent, envs, w.episodes, &w.groundTruth,
                          EvalConfig{});
}

TEST(OracleAgentTest, GoalOracleReproducesTheFollowersGroundTruth) {
  const auto& w = rolloutTestWorld();
  for (int numEnvs : {1, 3}) {
    SCOPED_TRACE(numEnvs);
    const EvaluationResult result = evaluateOracle(OracleMode::kGoal, numEnvs);
    ASSERT_EQ(result.episodes.size(), w.episodes.size());
    for (size_t i = 0; i < w.episodes.size(); ++i) {
      const EpisodeRecord& record = result.episodes[i].record;
      std::vector<int> expected;
      for (sim::Action a : w.groundTruth.at(w.episodes[i].episode_id).actions)
        expected.push_back(static_cast<int>(a));
      EXPECT_EQ(record.actions, expected) << "episode " << i;
      EXPECT_EQ(record.positions, w.followerPositions[i]) << "episode " << i;
      EXPECT_TRUE(record.called_stop);
      EXPECT_EQ(result.episodes[i].metrics.success, 1.0);
    }
    EXPECT_EQ(result.stats.mean.success, 1.0);
    EXPECT_GT(result.stats.mean.spl, 0.8);
  }
}

TEST(OracleAgentTest, ReferencePathOracleSucceedsToo) {
  const EvaluationResult result = evaluateOracle(OracleMode::kReferencePath, 2);
  EXPECT_EQ(result.stats.mean.success, 1.0);
}

TEST(OracleAgentTest, RefusesEpisodesWithoutGoalsAndBadEnvironments) {
  const auto& w = rolloutTestWorld();
  OracleAgent agent(w.sim.agent, 0.5f, OracleMode::kGoal, 2);
  EXPECT_FALSE(agent.needsObservations());
  data::Episode test = w.episodes.front();
  test.goals.clear();
  EXPECT_THAT(vln::test::errorOf([&] { agent.reset(0, test); }),
              HasSubstr("no goal for the oracle"));
  EXPECT_THAT(vln::test::errorOf([&] { agent.reset(2, w.episodes.front()); }),
              HasSubstr("OracleAgent::reset(): environment 2 out of range"));
  VectorEnv envs(2, w.sim, w.task, std::make_shared<SceneCache>(w.sim), 1);
  const std::vector<int> active = {1};
  EXPECT_THAT(vln::test::errorOf([&] { agent.act(envs, active); }),
              HasSubstr("environment 1 was never reset"));
  EXPECT_THAT(vln::test::errorOf([] {
                OracleAgent(sim::AgentConfig{}, 0.5f, OracleMode::kGoal, 0);
              }),
              HasSubstr("numEnvs must be >= 1"));
}

}  // namespace
}  // namespace vln::rollout
