// Tests src/waypoint/WaypointApproach.cpp: the turns towards a heading, the
// approach of a waypoint (turns, forward steps, stopped by an obstacle),
// a teleport's end, and the oracle's choice among candidates under either
// execution, in a room of known geometry.

#include "waypoint/WaypointApproach.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

#include "sim/NavMesh.h"
#include "sim/Scene.h"
#include "sim/SimTestScenes.h"
#include "sim/SimTestSuites.h"

namespace vln::waypoint {
namespace {

// 6 m x 6 m room (walls at x, z = +-3), a 1 m cube over x in [1.5, 2.5],
// z in [-0.5, 0.5]
std::shared_ptr<const sim::Scene> room() {
  return test::roomWithCube("approach-room", /*ceiling=*/false);
}

class WaypointApproachTest : public test::SceneSuite<room> {
 protected:
  static sim::AgentState at(float x, float z, float heading) {
    return {*scene_->navmesh().snapPoint({x, 0.0f, z}), heading, 0.0f};
  }
  static float degrees(float d) { return d * kPi / 180.0f; }
  sim::AgentConfig agent_;  // R2R: 15 degree turns, 0.25 m steps, sliding
  ApproachConfig config_;
};

TEST_F(WaypointApproachTest, TurnsRoundToTheNearestTurnAngle) {
  EXPECT_EQ(turnsTowards(agent_, 0.0f), 0);
  EXPECT_EQ(turnsTowards(agent_, degrees(30)), 2);    // left
  EXPECT_EQ(turnsTowards(agent_, degrees(-45)), -3);  // right
  EXPECT_EQ(turnsTowards(agent_, degrees(350)), -1);  // wraps: 10 right
  EXPECT_EQ(turnsTowards(agent_, degrees(97)), 6);    // 6.47 turns -> 6
  EXPECT_EQ(std::abs(turnsTowards(agent_, kPi)), 12);
}

TEST_F(WaypointApproachTest, WalksStraightToAnOpenWaypoint) {
  // from (-1, 0) facing -Z: 2 m ahead is open floor
  const sim::AgentState start = at(-1.0f, 0.0f, 0.0f);
  const Approach a =
      planApproach(scene_->navmesh(), agent_, start, 0.0f, 2.0f, config_);
  EXPECT_EQ(a.turns, 0);
  EXPECT_EQ(a.forward_steps, 8);
  EXPECT_FALSE(a.blocked);
  ASSERT_EQ(a.actions.size(), 8u);
  for (sim::Action action : a.actions)
    EXPECT_EQ(action, sim::Action::kMoveForward);
  EXPECT_NEAR(a.end.position.x(), -1.0f, 1e-3f);
  EXPECT_NEAR(a.end.position.z(), -2.0f, 1e-3f);
}

TEST_F(WaypointApproachTest, TurnsFirstThenWalks) {
  // 90 degrees left of -Z is -X: 1.5 m there from (0, 0)
  const sim::AgentState start = at(0.0f, 0.0f, 0.0f);
  const Approach a = planApproach(scene_->navmesh(), agent_, start, degrees(90),
                                  1.5f, config_);
  EXPECT_EQ(a.turns, 6);
  EXPECT_EQ(a.forward_steps, 6);
  ASSERT_EQ(a.actions.size(), 12u);
  for (int i = 0; i < 6; ++i) EXPECT_EQ(a.actions[i], sim::Action::kTurnLeft);
  EXPECT_NEAR(a.end.position.x(), -1.5f, 1e-3f);
  EXPECT_NEAR(a.end.position.z(), 0.0f, 1e-3f);
  EXPECT_NEAR(wrapAngle(a.end.heading - degrees(90)), 0.0f, 1e-4f);
}

TEST_F(WaypointApproachTest, AnObstacleEndsTheApproachWhereTheAgentIsStuck) {
  // facing +X (90 degrees right of -Z) from (0, 0): the cube's face at
  // x = 1.5 stops the agent short of a waypoint 3 m away, head on, so
  // sliding cannot carry it along
  const sim::AgentState start = at(0.0f, 0.0f, 0.0f);
  const Approach a = planApproach(scene_->navmesh(), agent_, start,
                                  degrees(-90), 3.0f, config_);
  EXPECT_EQ(a.turns, 6);
  EXPECT_TRUE(a.blocked);
  EXPECT_LT(a.forward_steps, 12);
  EXPECT_LT(a.end.position.x(), 1.5f);
  EXPECT_GT(a.end.position.x(), 1.0f);
  // the plan is what the environment will do: replaying it moves the same
  sim::AgentState replay = start;
  for (sim::Action action : a.actions)
    sim::applyAction(scene_->navmesh(), agent_, replay, action);
  EXPECT_EQ(replay, a.end);
}

TEST_F(WaypointApproachTest, OracleTakesTheCandidateNearestTheGoal) {
  const sim::AgentState start = at(-1.0f, 2.0f, 0.0f);
  const Vec3f goal = *scene_->navmesh().snapPoint({-1.0f, 0.0f, -2.5f});
  const std::vector<Candidate> candidates = {
      candidateAt(60, 7, 1.0f),  // behind (+Z), 2 m
      candidateAt(0, 7, 0.5f),   // ahead (-Z), 2 m: towards the goal
      candidateAt(30, 3, 0.2f),  // left, 1 m
  };
  EXPECT_EQ(
      oracleChoice(scene_->navmesh(), agent_, start, candidates, goal, config_),
      1);
}

// the verdict behind the choice: every candidate's end distance, and the
// choices within a tolerance of the chosen one's
TEST_F(WaypointApproachTest, VerdictAcceptsCandidatesWithinTheTolerance) {
  const sim::AgentState start = at(-1.0f, 2.0f, 0.0f);
  const Vec3f goal = *scene_->navmesh().snapPoint({-1.0f, 0.0f, -2.5f});
  const std::vector<Candidate> candidates = {
      candidateAt(60, 7, 1.0f),  // behind
      candidateAt(0, 7, 0.5f),   // ahead: towards the goal
      candidateAt(30, 3, 0.2f),  // left, 1 m
  };
  const OracleVerdict verdict = oracleVerdict(scene_->navmesh(), agent_, start,
                                              candidates, goal, config_);
  EXPECT_EQ(verdict.choice, oracleChoice(scene_->navmesh(), agent_, start,
                                         candidates, goal, config_));
  ASSERT_EQ(verdict.choice, 1);
  ASSERT_EQ(verdict.end_distances.size(), 3u);
  const std::vector<float>& d = verdict.end_distances;
  EXPECT_LT(d[1], d[2]);
  EXPECT_LT(d[2], d[0]);
  EXPECT_EQ(acceptableChoices(verdict, 0.0f), 1u << 2);
  EXPECT_EQ(acceptableChoices(verdict, d[2] - d[1] + 0.01f),
            (1u << 2) | (1u << 3));
  EXPECT_EQ(acceptableChoices(verdict, d[0] - d[1] + 0.01f), 0b1110u);

  // STOP accepts STOP alone
  const OracleVerdict stop =
      oracleVerdict(scene_->navmesh(), agent_, at(-1.0f, -1.5f, 0.0f),
                    candidates, goal, config_);
  EXPECT_EQ(stop.choice, -1);
  EXPECT_EQ(acceptableChoices(stop, 10.0f), 1u);

  // by hand: unreachable ends are never accepted
  const float inf = std::numeric_limits<float>::infinity();
  EXPECT_EQ(acceptableChoices({1, {3.0f, 2.0f, 2.2f, inf}}, 0.25f),
            (1u << 2) | (1u << 3));
  EXPECT_THROW(acceptableChoices(verdict, -0.1f), std::invalid_argument);
  EXPECT_THROW(acceptableChoices(verdict, std::nanf("")),
               std::invalid_argument);
  EXPECT_THROW(acceptableChoices({0, std::vector<float>(32, 1.0f)}, 0.5f),
               std::invalid_argument);
}

// With a corridor around the described path the oracle prefers the way the
// words go over a shortcut; without a candidate in the corridor it is the
// goal oracle again
TEST_F(WaypointApproachTest, ACorridorKeepsTheOracleOnTheDescribedPath) {
  const sim::AgentState start = at(-1.0f, 2.0f, 0.0f);
  const Vec3f goal = *scene_->navmesh().snapPoint({-1.0f, 0.0f, -2.5f});
  const std::vector<Candidate> candidates = {
      candidateAt(0, 7, 0.5f),   // ahead (-Z), 2 m: straight for the goal
      candidateAt(30, 3, 0.2f),  // left (-X), 1 m
  };
  // the described path goes left first, then ahead to the goal
  const std::vector<Vec3f> path = {
      start.position, *scene_->navmesh().snapPoint({-2.0f, 0.0f, 2.0f}),
      *scene_->navmesh().snapPoint({-2.0f, 0.0f, -2.5f}), goal};
  const PathCorridor corridor{path, 0.5f};
  const OracleVerdict free = oracleVerdict(scene_->navmesh(), agent_, start,
                                           candidates, goal, config_);
  const OracleVerdict kept =
      oracleVerdict(scene_->navmesh(), agent_, start, candidates, goal, config_,
                    Execution::kWalk, &corridor);
  EXPECT_EQ(free.choice, 0);
  EXPECT_EQ(kept.choice, 1);
  // every candidate's distance is reported either way
  EXPECT_EQ(kept.end_distances, free.end_distances);

  // a corridor no candidate ends in leaves the goal oracle's choice
  const std::vector<Vec3f> elsewhere = {
      *scene_->navmesh().snapPoint({2.5f, 0.0f, 2.5f}),
      *scene_->navmesh().snapPoint({2.5f, 0.0f, 1.0f})};
  const PathCorridor far{elsewhere, 0.5f};
  EXPECT_EQ(oracleVerdict(scene_->navmesh(), agent_, start, candidates, goal,
                          config_, Execution::kWalk, &far)
                .choice,
            0);
}

TEST(DistanceToPathTest, MeasuresToTheNearestSegment) {
  const std::vector<Vec3f> path = {
      {0.0f, 0.0f, 0.0f}, {2.0f, 0.0f, 0.0f}, {2.0f, 0.0f, 2.0f}};
  EXPECT_FLOAT_EQ(distanceToPath({1.0f, 0.0f, 0.5f}, path), 0.5f);
  EXPECT_FLOAT_EQ(distanceToPath({3.0f, 0.0f, 1.0f}, path), 1.0f);
  EXPECT_FLOAT_EQ(distanceToPath({-3.0f, 0.0f, -4.0f}, path), 5.0f);
  EXPECT_FLOAT_EQ(distanceToPath({1.0f, 0.0f, 1.0f}, std::span(path).first(1)),
                  std::sqrt(2.0f));
  EXPECT_TRUE(std::isinf(distanceToPath({0.0f, 0.0f, 0.0f}, {})));
}

TEST_F(WaypointApproachTest, OracleStopsNearTheGoalOrWithoutProgress) {
  const std::vector<Candidate> ahead = {candidateAt(0, 7, 1.0f)};
  // within stop_distance (1.5 m): STOP whatever the candidates
  const Vec3f goal = *scene_->navmesh().snapPoint({-1.0f, 0.0f, -1.0f});
  EXPECT_EQ(oracleChoice(scene_->navmesh(), agent_, at(-1.0f, 0.0f, 0.0f),
                         ahead, goal, config_),
            -1);
  // 2.5 m away (inside success_distance) and the only candidate leads away
  const Vec3f far = *scene_->navmesh().snapPoint({-1.0f, 0.0f, 2.5f});
  EXPECT_EQ(oracleChoice(scene_->navmesh(), agent_, at(-1.0f, 0.0f, 0.0f),
                         ahead, far, config_),
            -1);
  // no candidates at all
  EXPECT_EQ(oracleChoice(scene_->navmesh(), agent_, at(-1.0f, 2.0f, 0.0f), {},
                         goal, config_),
            -1);
  // farther than success_distance: the best candidate even if it leads away
  const Vec3f distant = *scene_->navmesh().snapPoint({-1.0f, 0.0f, 2.8f});
  EXPECT_EQ(oracleChoice(scene_->navmesh(), agent_, at(-1.0f, -2.0f, 0.0f),
                         ahead, distant, config_),
            0);
}

TEST_F(WaypointApproachTest, ATeleportLandsWhereAWalkIsStopped) {
  // east (90 degrees right of -Z), 3 m from (0, 0): the walk is stopped by
  // the cube's face at x = 1.5; the teleport passes it and its target on
  // the wall (x = 3) snaps to the floor's edge behind the cube
  const sim::NavMesh& navmesh = scene_->navmesh();
  const sim::AgentState start = at(0.0f, 0.0f, 0.0f);
  const sim::AgentState walked = executionEnd(
      navmesh, agent_, start, degrees(-90), 3.0f, config_, Execution::kWalk);
  EXPECT_EQ(
      walked,
      planApproach(navmesh, agent_, start, degrees(-90), 3.0f, config_).end);
  EXPECT_LT(walked.position.x(), 1.5f);
  const sim::AgentState target = teleportTarget(start, degrees(-90), 3.0f);
  EXPECT_NEAR(target.position.x(), 3.0f, 1e-5f);
  EXPECT_NEAR(target.position.z(), 0.0f, 1e-5f);
  EXPECT_NEAR(wrapAngle(target.heading - degrees(-90)), 0.0f, 1e-5f);
  const sim::AgentState teleported =
      executionEnd(navmesh, agent_, start, degrees(-90), 3.0f, config_,
                   Execution::kTeleport);
  EXPECT_EQ(teleported, sim::resolveTeleport(navmesh, start, target).end);
  EXPECT_GT(teleported.position.x(), 2.5f);
  EXPECT_LT(teleported.position.x(), 3.0f);
  EXPECT_NEAR(teleported.position.z(), 0.0f, 0.05f);

  // so the oracle labels differently: for a goal just behind the cube the
  // walker's best is to go round it south-east, the teleporter jumps east
  const Vec3f goal = *navmesh.snapPoint({2.75f, 0.0f, 0.0f});
  const std::vector<Candidate> candidates = {
      candidateAt(90, 11, 1.0f),  // 270 degrees = 90 right (+X), 3 m
      candidateAt(75, 7, 1.0f),   // 225 degrees: south-east, 2 m
  };
  EXPECT_EQ(oracleChoice(navmesh, agent_, start, candidates, goal, config_,
                         Execution::kWalk),
            1);
  EXPECT_EQ(oracleChoice(navmesh, agent_, start, candidates, goal, config_),
            1);  // walking is the default
  EXPECT_EQ(oracleChoice(navmesh, agent_, start, candidates, goal, config_,
                         Execution::kTeleport),
            0);
}

}  // namespace
}  // namespace vln::waypoint
