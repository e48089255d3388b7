#include "sim/Follower.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <random>
#include <vector>

#include "sim/SimTestScenes.h"
#include "sim/SimTestSuites.h"

namespace vln::sim {
namespace {

using test::addBox;
using test::kSlab;
using test::kWallTop;
using test::wallAlongX;
using test::wallAlongZ;
using ::testing::HasSubstr;
using ::testing::ThrowsMessage;

// Three rooms in a 12 x 8 m house, joined by 1.2 m doorways at different
// heights of the dividing walls, with a half wall in the third room, four
// pillars and a table (a separate island) in the first room.
TriangleMesh threeRoomHouse() {
  TriangleMesh m;
  test::addWalledFloor(m, 12, 8);
  wallAlongZ(m, 4, 0, 3);  // doorway z in [3, 4.2]
  wallAlongZ(m, 4, 4.2f, 8);
  wallAlongZ(m, 8, 0, 5.5f);  // doorway z in [5.5, 6.7]
  wallAlongZ(m, 8, 6.7f, 8);
  wallAlongX(m, 3.5f, 8, 10.5f);  // half wall in room 3
  for (const Vec2f& c :
       {Vec2f(2, 2), Vec2f(6, 5.5f), Vec2f(5.5f, 2), Vec2f(10, 6)})
    addBox(m, {c.x() - 0.2f, 0, c.y() - 0.2f},
           {c.x() + 0.2f, kWallTop, c.y() + 0.2f});
  addBox(m, {1, 0, 5}, {2.6f, 0.75f, 6.6f});  // table
  return m;
}

class FollowerTest : public test::NavMeshSuite<threeRoomHouse> {};

TEST_F(FollowerTest, SceneHasTheExpectedIslands) {
  ASSERT_EQ(navmesh().islandCount(), 2);  // floor and table top
  EXPECT_EQ(navmesh().islandIndex(navmesh().snapPoint({1.0f, 0, 1.0f}).value()),
            0);
  EXPECT_EQ(navmesh().islandIndex({1.8f, 0.75f, 5.8f}), 1);
}

TEST_F(FollowerTest, StopsWithinTheGoalRadius) {
  const ShortestPathFollower follower(navmesh(), AgentConfig{}, 0.5f);
  const AgentState state = standing(1.0f, 1.0f, 0.0f);
  EXPECT_EQ(follower.nextAction(state, state.position), Action::kStop);
  EXPECT_EQ(follower.nextAction(state, state.position + Vec3f(0.4f, 0, 0)),
            Action::kStop);
  EXPECT_NE(follower.nextAction(state, state.position + Vec3f(0.6f, 0, 0)),
            Action::kStop);
}

TEST_F(FollowerTest, StopsWhenTheGoalIsUnreachable) {
  const ShortestPathFollower follower(navmesh(), AgentConfig{}, 0.5f);
  const AgentState state = standing(1.0f, 1.0f, 0.0f);
  EXPECT_EQ(follower.nextAction(state, {1.8f, 0.75f, 5.8f}), Action::kStop);
  EXPECT_EQ(follower.nextAction(state, {40.0f, 0.0f, 40.0f}), Action::kStop);
}

TEST_F(FollowerTest, NonFiniteOrFarAwayStatesAreRefused) {
  const ShortestPathFollower follower(navmesh(), AgentConfig{}, 0.5f);
  const AgentState state = standing(1.0f, 1.0f, 0.0f);
  const Vec3f goal = standing(3.0f, 1.0f, 0.0f).position;
  for (float heading : {NAN, INFINITY}) {
    EXPECT_THAT(
        [&] {
          follower.nextAction({state.position, heading}, goal);
        },
        ThrowsMessage<std::invalid_argument>(
            HasSubstr("ShortestPathFollower::nextAction(): agent heading")));
  }
  EXPECT_THAT(
      [&] {
        follower.nextAction({Vec3f(1e30f, 0, 1), 0.0f}, goal);
      },
      ThrowsMessage<std::invalid_argument>(HasSubstr("outside the scene")));
  EXPECT_THAT(
      [&] { follower.nextAction(state, Vec3f(1, NAN, 1)); },
      ThrowsMessage<std::invalid_argument>(HasSubstr("must be finite")));
}

TEST_F(FollowerTest, TurnsTowardsTheNextCorner) {
  // goal 2 m in open floor along -Z, the agent's heading varies
  const ShortestPathFollower follower(navmesh(), AgentConfig{}, 0.5f);
  const Vec3f goal = standing(1.0f, 1.0f, 0.0f).position;
  auto actionAt = [&](float headingDegrees) {
    return follower.nextAction(standing(1.0f, 3.0f, degToRad(headingDegrees)),
                               goal);
  };
  EXPECT_EQ(actionAt(0.0f), Action::kMoveForward);
  EXPECT_EQ(actionAt(14.9f), Action::kMoveForward);  // within turn_angle
  EXPECT_EQ(actionAt(-14.9f), Action::kMoveForward);
  EXPECT_EQ(actionAt(16.0f), Action::kTurnRight);  // left of the goal
  EXPECT_EQ(actionAt(-16.0f), Action::kTurnLeft);
  EXPECT_EQ(actionAt(90.0f), Action::kTurnRight);
  EXPECT_EQ(actionAt(-120.0f), Action::kTurnLeft);

  AgentConfig wide;
  wide.turn_angle = 30.0f;
  const ShortestPathFollower wideFollower(navmesh(), wide, 0.5f);
  EXPECT_EQ(
      wideFollower.nextAction(standing(1.0f, 3.0f, degToRad(25.0f)), goal),
      Action::kMoveForward);
}

TEST_F(FollowerTest, HeadsForTheDoorwayNotTheGoal) {
  // from room 1 to room 2 the first corner is at the doorway (x = 4,
  // z in [3, 4.2]), far to the side of the straight line to the goal
  const ShortestPathFollower follower(navmesh(), AgentConfig{}, 0.5f);
  const Vec3f goal = standing(6.0f, 0.8f, 0.0f).position;
  // facing the goal (+X, heading -pi/2) the wall is in the way and the
  // doorway (towards +Z) lies to the agent's right: +X x +Y = +Z
  const AgentState facingGoal = standing(3.0f, 0.8f, -kPi / 2.0f);
  EXPECT_EQ(follower.nextAction(facingGoal, goal), Action::kTurnRight);
  // facing away (-X), the doorway is on the left
  const AgentState facingAway = standing(3.0f, 0.8f, kPi / 2.0f);
  EXPECT_EQ(follower.nextAction(facingAway, goal), Action::kTurnLeft);
  // facing the doorway, it walks
  const Vec3f door(4.0f, 0.0f, 3.6f);
  const AgentState facingDoor =
      standing(3.0f, 0.8f, forwardToHeading(door - Vec3f(3.0f, 0.0f, 0.8f)));
  EXPECT_EQ(follower.nextAction(facingDoor, goal), Action::kMoveForward);
}

TEST_F(FollowerTest, FollowingReachesRandomGoalsOnTheSameIsland) {
  // VLN-CE's oracle setting: 0.25 m steps, 15 degree turns, sliding
  const AgentConfig agent;
  TaskConfig task;
  task.max_episode_steps = 500;
  const float goalRadius = task.follower_goal_radius;
  const ShortestPathFollower follower(navmesh(), agent, goalRadius);
  std::mt19937_64 rng(2024);

  int reachedCount = 0;
  constexpr int kEpisodes = 100;
  for (int e = 0; e < kEpisodes; ++e) {
    const Vec3f start = navmesh().randomPoint(rng, /*island=*/0);
    const Vec3f goal = navmesh().randomPoint(rng, /*island=*/0);
    const float geodesic = navmesh().geodesicDistance(start, goal);
    ASSERT_TRUE(std::isfinite(geodesic));
    const auto path = navmesh().shortestPath(start, goal);
    EpisodeState episode;
    episode.agent.position = start;
    episode.agent.heading =
        static_cast<float>(rng() % 360) * kPi / 180.0f - kPi;
    while (!episode.done) {
      const Action action = follower.nextAction(episode.agent, goal);
      stepEpisode(navmesh(), agent, task, episode, action);
    }
    // it stops of its own accord, within the radius
    ASSERT_TRUE(episode.called_stop)
        << "episode " << e << " from " << start.transpose() << " to "
        << goal.transpose() << " (geodesic " << geodesic
        << ") ran out of steps";
    const float left = navmesh().geodesicDistance(episode.agent.position, goal);
    EXPECT_LE(left, goalRadius) << "episode " << e;
    // and in few steps: a forward step per 0.25 m of path (15% slack for
    // sliding around corners), a half circle of turns at the start and one
    // more at every corner of the path, and the STOP
    const int corners = static_cast<int>(path.size());
    const int bound = static_cast<int>(std::ceil(1.15f * geodesic / 0.25f)) +
                      12 * corners + 1;
    EXPECT_LE(episode.steps, bound)
        << "episode " << e << ", geodesic " << geodesic;
    reachedCount += left <= goalRadius ? 1 : 0;
  }
  EXPECT_EQ(reachedCount, kEpisodes);
}

TEST(FollowerConfig, RejectsANonPositiveGoalRadius) {
  TriangleMesh slab;
  addBox(slab, {0, -kSlab, 0}, {3, 0, 3});
  const auto nav = NavMesh::build(slab, NavMeshConfig{});
  EXPECT_THROW(ShortestPathFollower(*nav, AgentConfig{}, 0.0f),
               std::invalid_argument);
}

// ---------------------------------------------------------------------------
// a pitched camera (RxR's action space)
// ---------------------------------------------------------------------------

AgentConfig lookConfig() {
  AgentConfig config;
  config.look_actions = true;
  config.turn_angle = 30.0f;
  config.tilt_angle = 30.0f;
  return config;
}

TEST_F(FollowerTest, LevelsAPitchedCameraBeforeMoving) {
  // goal 2 m ahead in open floor: forward once the camera is level
  const ShortestPathFollower follower(navmesh(), lookConfig(), 0.5f);
  const Vec3f goal = standing(1.0f, 1.0f, 0.0f).position;
  auto actionAt = [&](float pitchDegrees) {
    AgentState state = standing(1.0f, 3.0f, 0.0f);
    state.pitch = degToRad(pitchDegrees);
    return follower.nextAction(state, goal);
  };
  EXPECT_EQ(actionAt(0.0f), Action::kMoveForward);
  EXPECT_EQ(actionAt(30.0f), Action::kLookDown);
  EXPECT_EQ(actionAt(60.0f), Action::kLookDown);
  EXPECT_EQ(actionAt(-30.0f), Action::kLookUp);
  EXPECT_EQ(actionAt(-90.0f), Action::kLookUp);
  // upside down (six looks up) either way round
  EXPECT_EQ(actionAt(180.0f), Action::kLookDown);
  // within half a tilt of level no look gets closer: it moves on
  EXPECT_EQ(actionAt(14.0f), Action::kMoveForward);
  EXPECT_EQ(actionAt(-14.0f), Action::kMoveForward);
  // a turn waits for the level camera too
  AgentState turned = standing(1.0f, 3.0f, degToRad(90.0f));
  turned.pitch = degToRad(-30.0f);
  EXPECT_EQ(follower.nextAction(turned, goal), Action::kLookUp);
  turned.pitch = 0.0f;
  EXPECT_EQ(follower.nextAction(turned, goal), Action::kTurnRight);
}

TEST_F(FollowerTest, StopsWithoutLevelling) {
  // STOP needs no view: a pitched agent at the goal stops at once
  const ShortestPathFollower follower(navmesh(), lookConfig(), 0.5f);
  AgentState state = standing(1.0f, 1.0f, 0.0f);
  state.pitch = degToRad(-60.0f);
  EXPECT_EQ(follower.nextAction(state, state.position), Action::kStop);
}

TEST_F(FollowerTest, DrivesAPitchedAgentToTheGoal) {
  // following the follower from a camera looking 60 degrees down: two
  // LOOK_UPs first, then the level R2R route, never another look
  const AgentConfig config = lookConfig();
  const ShortestPathFollower follower(navmesh(), config, 0.5f);
  const Vec3f goal = standing(10.0f, 2.0f, 0.0f).position;
  AgentState level = standing(1.0f, 1.0f, 0.0f);
  AgentState pitched = level;
  pitched.pitch = degToRad(-60.0f);
  std::vector<Action> levelActions;
  std::vector<Action> pitchedActions;
  for (int i = 0; i < 200; ++i) {
    const Action a = follower.nextAction(level, goal);
    levelActions.push_back(a);
    if (a == Action::kStop) break;
    applyAction(navmesh(), config, level, a);
  }
  for (int i = 0; i < 200; ++i) {
    const Action a = follower.nextAction(pitched, goal);
    pitchedActions.push_back(a);
    if (a == Action::kStop) break;
    applyAction(navmesh(), config, pitched, a);
  }
  ASSERT_EQ(levelActions.back(), Action::kStop);
  ASSERT_GE(pitchedActions.size(), 2u);
  EXPECT_EQ(pitchedActions[0], Action::kLookUp);
  EXPECT_EQ(pitchedActions[1], Action::kLookUp);
  EXPECT_EQ(
      std::vector<Action>(pitchedActions.begin() + 2, pitchedActions.end()),
      levelActions);
  EXPECT_NEAR(pitched.pitch, 0.0f, 1e-5f);
  EXPECT_EQ(pitched.position, level.position);
}

TEST_F(FollowerTest, WithoutLookActionsThePitchIsIgnored) {
  // the R2R action space cannot level a camera, so it does not try
  AgentConfig r2r = lookConfig();
  r2r.look_actions = false;
  const ShortestPathFollower follower(navmesh(), r2r, 0.5f);
  AgentState state = standing(1.0f, 3.0f, 0.0f);
  state.pitch = degToRad(-30.0f);
  EXPECT_EQ(follower.nextAction(state, standing(1.0f, 1.0f, 0.0f).position),
            Action::kMoveForward);
  state.pitch = NAN;
  EXPECT_THAT(
      [&] { follower.nextAction(state, state.position); },
      ThrowsMessage<std::invalid_argument>(HasSubstr("must be finite")));
}

}  // namespace
}  // namespace vln::sim
