#include "sim/Agent.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "sim/NavMesh.h"
#include "sim/SimTestScenes.h"
#include "sim/SimTestSuites.h"

namespace vln::sim {
namespace {

using test::addBox;
using test::kSlab;
using test::kWall;
using test::kWallTop;
using ::testing::HasSubstr;

// A walled 6 x 6 m room (x, z in [0, 6]) whose east half continues, past
// x = 6, into a 4 m ramp rising 1 m (14 degrees) to a landing.
TriangleMesh roomWithRamp() {
  TriangleMesh m;
  addBox(m, {0, -kSlab, 0}, {6, 0, 6});
  addBox(m, {-kWall, -kSlab, -kWall}, {6, kWallTop, 0});     // north (-z)
  addBox(m, {-kWall, -kSlab, 6}, {6, kWallTop, 6 + kWall});  // south
  addBox(m, {-kWall, -kSlab, 0}, {0, kWallTop, 6});          // west
  addBox(m, {6, -kSlab, 0}, {6 + kWall, kWallTop, 3});       // east, north half
  const auto base = static_cast<uint32_t>(m.positions.size());
  m.positions.insert(m.positions.end(),
                     {{6, 0, 3}, {10, 1, 3}, {10, 1, 6}, {6, 0, 6}});
  m.indices.insert(m.indices.end(),
                   {base, base + 3, base + 2, base, base + 2, base + 1});
  addBox(m, {10, 1 - kSlab, 3}, {12, 1, 6});
  return m;
}

class AgentTest : public test::NavMeshSuite<roomWithRamp> {};

// ---------------------------------------------------------------------------
// action names and codes
// ---------------------------------------------------------------------------

TEST(ActionTest, NamesAndCodesFollowTheDataset) {
  EXPECT_EQ(actionName(Action::kStop), "STOP");
  EXPECT_EQ(actionName(Action::kMoveForward), "MOVE_FORWARD");
  EXPECT_EQ(actionName(Action::kTurnLeft), "TURN_LEFT");
  EXPECT_EQ(actionName(Action::kTurnRight), "TURN_RIGHT");
  for (int code = 0; code < kNumActions; ++code)
    EXPECT_EQ(static_cast<int>(actionFromInt(code)), code);
  try {
    actionFromInt(4);
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("got 4"));
  }
  EXPECT_THROW(actionFromInt(-1), std::invalid_argument);
}

TEST(ActionTest, LookActionsFollowTheR2RActions) {
  // Habitat's HabitatSimActions order: LOOK_UP = 4, LOOK_DOWN = 5
  EXPECT_EQ(static_cast<int>(Action::kLookUp), 4);
  EXPECT_EQ(static_cast<int>(Action::kLookDown), 5);
  EXPECT_EQ(actionName(Action::kLookUp), "LOOK_UP");
  EXPECT_EQ(actionName(Action::kLookDown), "LOOK_DOWN");
  for (int code = 0; code < kNumLookActions; ++code)
    EXPECT_EQ(static_cast<int>(actionFromInt(code, kNumLookActions)), code);
  EXPECT_THAT([] { actionFromInt(6, kNumLookActions); },
              ::testing::ThrowsMessage<std::invalid_argument>(
                  HasSubstr("must be in 0..5, got 6")));
  // the R2R action space is the default and the smaller one
  AgentConfig config;
  EXPECT_EQ(numActions(config), kNumActions);
  config.look_actions = true;
  EXPECT_EQ(numActions(config), kNumLookActions);
}

// ---------------------------------------------------------------------------
// turning and moving
// ---------------------------------------------------------------------------

TEST_F(AgentTest, TurnsChangeOnlyTheHeading) {
  const AgentConfig config;
  AgentState state = standing(3.0f, 3.0f, 0.0f);
  const Vec3f start = state.position;

  StepResult r = applyAction(navmesh(), config, state, Action::kTurnLeft);
  EXPECT_NEAR(state.heading, degToRad(15.0f), 1e-6f);  // left is +
  EXPECT_FALSE(r.collided);
  EXPECT_EQ(r.distance, 0.0f);
  EXPECT_EQ(state.position, start);

  applyAction(navmesh(), config, state, Action::kTurnRight);
  applyAction(navmesh(), config, state, Action::kTurnRight);
  EXPECT_NEAR(state.heading, degToRad(-15.0f), 1e-6f);

  // a full circle of left turns comes back, with the heading kept wrapped
  for (int i = 0; i < 24; ++i) {
    applyAction(navmesh(), config, state, Action::kTurnLeft);
    EXPECT_GT(state.heading, -kPi);
    EXPECT_LE(state.heading, kPi);
  }
  EXPECT_NEAR(state.heading, degToRad(-15.0f), 1e-5f);

  AgentConfig coarse;
  coarse.turn_angle = 30.0f;
  applyAction(navmesh(), coarse, state, Action::kTurnLeft);
  EXPECT_NEAR(state.heading, degToRad(15.0f), 1e-5f);
}

TEST_F(AgentTest, StopLeavesTheStateUnchanged) {
  AgentState state = standing(3.0f, 3.0f, 0.3f);
  const AgentState before = state;
  const StepResult r =
      applyAction(navmesh(), AgentConfig{}, state, Action::kStop);
  EXPECT_EQ(state, before);
  EXPECT_FALSE(r.collided);
}

TEST_F(AgentTest, MoveForwardFollowsTheHeading) {
  // heading 0 looks along -Z; heading pi/2 (a quarter turn left) along -X
  AgentState state = standing(3.0f, 3.0f, 0.0f);
  const Vec3f start = state.position;
  StepResult r =
      applyAction(navmesh(), AgentConfig{}, state, Action::kMoveForward);
  EXPECT_FALSE(r.collided);
  EXPECT_NEAR(r.distance, 0.25f, 1e-5f);
  EXPECT_NEAR(state.position.x(), start.x(), 1e-5f);
  EXPECT_NEAR(state.position.z(), start.z() - 0.25f, 1e-5f);

  state.heading = kPi / 2.0f;
  const Vec3f mid = state.position;
  AgentConfig longStep;
  longStep.forward_step_size = 0.5f;
  r = applyAction(navmesh(), longStep, state, Action::kMoveForward);
  EXPECT_FALSE(r.collided);
  EXPECT_NEAR(state.position.x(), mid.x() - 0.5f, 1e-5f);
  EXPECT_NEAR(state.position.z(), mid.z(), 1e-5f);
}

TEST_F(AgentTest, SlidingAlongAWallAtAnAngle) {
  // 0.2 m from the west wall's navmesh edge region, heading 45 degrees
  // between -Z and -X: the step would cross the edge, so the agent slides
  // north along it
  AgentState state = standing(0.25f, 3.0f, degToRad(45.0f));
  const Vec3f start = state.position;
  const StepResult r =
      applyAction(navmesh(), AgentConfig{}, state, Action::kMoveForward);
  EXPECT_TRUE(r.collided);
  EXPECT_LT(r.distance, 0.25f);
  EXPECT_GT(r.distance, 0.1f);  // it did slide
  EXPECT_NEAR(r.distance, (state.position - start).norm(), 1e-6f);
  EXPECT_LT(state.position.z(), start.z() - 0.1f);  // along the wall
  EXPECT_LT(state.position.x(), start.x());
  EXPECT_GT(state.position.x(), 0.1f);  // kept off the wall
  EXPECT_TRUE(navmesh().isNavigable(state.position));
}

TEST_F(AgentTest, WithoutSlidingABlockedAgentStaysPut) {
  AgentConfig noSlide;
  noSlide.allow_sliding = false;
  AgentState state = standing(0.25f, 3.0f, degToRad(45.0f));
  const AgentState before = state;
  const StepResult r =
      applyAction(navmesh(), noSlide, state, Action::kMoveForward);
  EXPECT_TRUE(r.collided);
  EXPECT_EQ(r.distance, 0.0f);
  EXPECT_EQ(state, before);

  // an unobstructed step is not affected by the setting
  AgentState open = standing(3.0f, 3.0f, degToRad(45.0f));
  const StepResult free =
      applyAction(navmesh(), noSlide, open, Action::kMoveForward);
  EXPECT_FALSE(free.collided);
  EXPECT_NEAR(free.distance, 0.25f, 1e-5f);
}

TEST_F(AgentTest, WalkingHeadOnIntoAWallCollidesWithoutMoving) {
  // facing -X at the west edge: nowhere to slide
  AgentState state = standing(0.0f, 3.0f, kPi / 2.0f);
  const Vec3f start = state.position;
  const StepResult r =
      applyAction(navmesh(), AgentConfig{}, state, Action::kMoveForward);
  EXPECT_TRUE(r.collided);
  EXPECT_LT(r.distance, 1e-3f);
  EXPECT_NEAR(state.position.x(), start.x(), 1e-3f);
}

TEST_F(AgentTest, ClimbingARampIsNotACollision) {
  // facing +X (heading -pi/2) at the foot of the ramp: each step rises, so
  // the 3-D move is longer than the intended horizontal one, which Habitat
  // does not count as a collision
  AgentState state = standing(6.5f, 4.5f, -kPi / 2.0f);
  float previousY = state.position.y();
  for (int i = 0; i < 8; ++i) {
    const StepResult r =
        applyAction(navmesh(), AgentConfig{}, state, Action::kMoveForward);
    EXPECT_FALSE(r.collided) << "step " << i;
    EXPECT_GE(r.distance, 0.25f - 1e-5f);
    EXPECT_GE(state.position.y(), previousY - 1e-4f);
    previousY = state.position.y();
  }
  EXPECT_NEAR(state.position.x(), 8.5f, 1e-3f);
  // 2.5 m up a 1-in-4 ramp is 0.625 m. Recast rounds span tops up to the
  // next cell_height and contour corners take the highest neighbouring
  // span, so the navmesh lies up to two cell heights above the surface.
  const float ch = NavMeshConfig{}.cell_height;
  EXPECT_GE(state.position.y(), 0.625f - 1e-3f);
  EXPECT_LE(state.position.y(), 0.625f + 2.0f * ch);
}

// ---------------------------------------------------------------------------
// episodes
// ---------------------------------------------------------------------------

TEST_F(AgentTest, StopEndsTheEpisode) {
  EpisodeState episode;
  episode.agent = standing(3.0f, 3.0f, 0.0f);
  const TaskConfig task;
  stepEpisode(navmesh(), AgentConfig{}, task, episode, Action::kTurnLeft);
  EXPECT_EQ(episode.steps, 1);
  EXPECT_FALSE(episode.done);
  stepEpisode(navmesh(), AgentConfig{}, task, episode, Action::kStop);
  EXPECT_EQ(episode.steps, 2);
  EXPECT_TRUE(episode.called_stop);
  EXPECT_TRUE(episode.done);
}

TEST_F(AgentTest, TheStepLimitEndsTheEpisodeWithoutStop) {
  EpisodeState episode;
  episode.agent = standing(0.25f, 3.0f, degToRad(45.0f));
  TaskConfig task;
  task.max_episode_steps = 3;
  stepEpisode(navmesh(), AgentConfig{}, task, episode, Action::kMoveForward);
  EXPECT_TRUE(episode.last_collided);  // the first step hits the wall
  stepEpisode(navmesh(), AgentConfig{}, task, episode, Action::kTurnRight);
  EXPECT_FALSE(episode.last_collided);
  EXPECT_FALSE(episode.done);
  stepEpisode(navmesh(), AgentConfig{}, task, episode, Action::kTurnRight);
  EXPECT_EQ(episode.steps, 3);
  EXPECT_TRUE(episode.done);
  EXPECT_FALSE(episode.called_stop);
}

TEST_F(AgentTest, NonFiniteOrFarAwayStatesAreRefused) {
  // a pose from a file or a caller is checked before Detour sees it
  const AgentConfig config;
  for (const AgentState& bad :
       {AgentState{Vec3f(1e30f, 0, 0), 0.0f},
        AgentState{Vec3f(NAN, 0, 1), 0.0f}, AgentState{Vec3f(1, 0, 1), NAN},
        AgentState{Vec3f(1, 0, 1), INFINITY},
        AgentState{Vec3f(500, 0, 1), 0.0f}}) {
    for (Action action : {Action::kMoveForward, Action::kTurnLeft}) {
      AgentState state = bad;
      EXPECT_THAT([&] { applyAction(navmesh(), config, state, action); },
                  ::testing::ThrowsMessage<std::invalid_argument>(
                      HasSubstr("applyAction(): agent")));
    }
  }
  // a finite heading of any size is fine
  AgentState turning = standing(1.0f, 1.0f, 1e30f);
  applyAction(navmesh(), config, turning, Action::kTurnLeft);
  EXPECT_TRUE(std::isfinite(turning.heading));
}

TEST_F(AgentTest, SteppingAFinishedEpisodeIsABug) {
  EpisodeState episode;
  episode.agent = standing(3.0f, 3.0f, 0.0f);
  episode.done = true;
  EXPECT_DEATH(stepEpisode(navmesh(), AgentConfig{}, TaskConfig{}, episode,
                           Action::kMoveForward),
               "episode.done");
}

// ---------------------------------------------------------------------------
// looking up and down (RxR's action space)
// ---------------------------------------------------------------------------

AgentConfig lookConfig() {
  AgentConfig config;
  config.look_actions = true;
  config.tilt_angle = 30.0f;
  return config;
}

TEST_F(AgentTest, LookActionsChangeOnlyThePitch) {
  const AgentConfig config = lookConfig();
  AgentState state = standing(3.0f, 3.0f, 0.7f);
  const AgentState start = state;

  StepResult r = applyAction(navmesh(), config, state, Action::kLookUp);
  EXPECT_NEAR(state.pitch, degToRad(30.0f), 1e-6f);  // up is +
  EXPECT_FALSE(r.collided);
  EXPECT_EQ(r.distance, 0.0f);
  EXPECT_EQ(state.position, start.position);
  EXPECT_EQ(state.heading, start.heading);

  applyAction(navmesh(), config, state, Action::kLookDown);
  r = applyAction(navmesh(), config, state, Action::kLookDown);
  EXPECT_NEAR(state.pitch, degToRad(-30.0f), 1e-6f);
  EXPECT_FALSE(r.collided);
  EXPECT_EQ(state.position, start.position);
  EXPECT_EQ(state.heading, start.heading);

  // the tilt is its own setting, not the turn angle
  AgentConfig fine = config;
  fine.tilt_angle = 10.0f;
  AgentState level = start;
  applyAction(navmesh(), fine, level, Action::kLookUp);
  EXPECT_NEAR(level.pitch, degToRad(10.0f), 1e-6f);
}

TEST_F(AgentTest, LookActionsAreUnclampedAsHabitatsV1) {
  // Habitat's v1 LOOK_UP has no actuation constraint: six looks up turn the
  // camera upside down (180 degrees), a seventh to -150 degrees
  const AgentConfig config = lookConfig();
  AgentState state = standing(3.0f, 3.0f, 0.0f);
  for (int i = 0; i < 6; ++i)
    applyAction(navmesh(), config, state, Action::kLookUp);
  EXPECT_NEAR(std::abs(state.pitch), kPi, 1e-5f);
  applyAction(navmesh(), config, state, Action::kLookUp);
  EXPECT_NEAR(state.pitch, degToRad(-150.0f), 1e-5f);
  // seven looks down undo them: the pitch stays wrapped to (-pi, pi]
  for (int i = 0; i < 7; ++i)
    applyAction(navmesh(), config, state, Action::kLookDown);
  EXPECT_NEAR(state.pitch, 0.0f, 1e-5f);
  EXPECT_GT(state.pitch, -kPi);
  EXPECT_LE(state.pitch, kPi);
}

TEST_F(AgentTest, LookActionsNeedTheRxrActionSpace) {
  AgentState state = standing(3.0f, 3.0f, 0.0f);
  for (Action action : {Action::kLookUp, Action::kLookDown})
    EXPECT_THAT([&] { applyAction(navmesh(), AgentConfig{}, state, action); },
                ::testing::ThrowsMessage<std::invalid_argument>(
                    ::testing::AllOf(HasSubstr(std::string(actionName(action))),
                                     HasSubstr("sim.agent.look_actions"))));
  EXPECT_EQ(state.pitch, 0.0f);
}

TEST_F(AgentTest, APitchThatIsNotFiniteIsRefused) {
  for (float pitch : {NAN, INFINITY}) {
    AgentState state = standing(3.0f, 3.0f, 0.0f);
    state.pitch = pitch;
    EXPECT_THAT(
        [&] { applyAction(navmesh(), lookConfig(), state, Action::kStop); },
        ::testing::ThrowsMessage<std::invalid_argument>(
            HasSubstr("camera pitch must be finite")));
  }
}

TEST_F(AgentTest, ThePitchDoesNotSteerTheBody) {
  // MOVE_FORWARD and the turns act on the body alone: a pitched camera
  // moves and turns exactly as a level one and keeps its pitch
  const AgentConfig config = lookConfig();
  for (Action action :
       {Action::kMoveForward, Action::kTurnLeft, Action::kTurnRight}) {
    AgentState level = standing(3.0f, 3.0f, 0.3f);
    AgentState pitched = level;
    pitched.pitch = degToRad(-60.0f);
    const StepResult a = applyAction(navmesh(), config, level, action);
    const StepResult b = applyAction(navmesh(), config, pitched, action);
    EXPECT_EQ(pitched.position, level.position);
    EXPECT_EQ(pitched.heading, level.heading);
    EXPECT_EQ(pitched.pitch, degToRad(-60.0f));
    EXPECT_EQ(b.distance, a.distance);
    EXPECT_EQ(b.collided, a.collided);
  }
}

TEST_F(AgentTest, R2rActionsAreUnchangedByTheLookActions) {
  // the same R2R action sequence, with and without the RxR action space,
  // visits exactly the same states and never pitches the camera
  const std::vector<Action> actions = {
      Action::kMoveForward, Action::kTurnLeft,  Action::kMoveForward,
      Action::kTurnRight,   Action::kTurnRight, Action::kMoveForward,
      Action::kMoveForward, Action::kTurnLeft,  Action::kStop};
  AgentState r2r = standing(1.0f, 1.0f, 0.0f);
  AgentState rxr = r2r;
  AgentConfig withLooks;
  withLooks.look_actions = true;
  for (Action action : actions) {
    const StepResult a = applyAction(navmesh(), AgentConfig{}, r2r, action);
    const StepResult b = applyAction(navmesh(), withLooks, rxr, action);
    EXPECT_EQ(rxr, r2r);
    EXPECT_EQ(r2r.pitch, 0.0f);
    EXPECT_EQ(b.distance, a.distance);
    EXPECT_EQ(b.collided, a.collided);
  }
}

TEST_F(AgentTest, EpisodesCountLookActionsAsSteps) {
  // a look is an action like any other: it counts toward
  // max_episode_steps (VLN-CE's steps_taken) and never ends the episode
  TaskConfig task;
  task.max_episode_steps = 3;
  EpisodeState episode;
  episode.agent = standing(3.0f, 3.0f, 0.0f);
  stepEpisode(navmesh(), lookConfig(), task, episode, Action::kLookDown);
  stepEpisode(navmesh(), lookConfig(), task, episode, Action::kLookUp);
  EXPECT_EQ(episode.steps, 2);
  EXPECT_FALSE(episode.done);
  EXPECT_FALSE(episode.called_stop);
  stepEpisode(navmesh(), lookConfig(), task, episode, Action::kLookUp);
  EXPECT_TRUE(episode.done);
  EXPECT_FALSE(episode.called_stop);
}

// ---------------------------------------------------------------------------
// teleporting (a waypoint agent's waypoint_agent.execution teleport)
// ---------------------------------------------------------------------------

// roomWithTable(): the floor (island 0) and the table top (island 1) over
// x, z in [2.25, 3.75] at 0.75 m
class TeleportTest : public test::NavMeshSuite<test::roomWithTable> {
 protected:
  static AgentState target(float x, float z, float heading) {
    return {Vec3f(x, 0.0f, z), heading, 0.0f};
  }
};

TEST(ActionTest, TeleportIsOutsideBothActionSpaces) {
  EXPECT_EQ(actionName(Action::kTeleport), "TELEPORT");
  EXPECT_EQ(static_cast<int>(Action::kTeleport), kNumLookActions);
  EXPECT_THROW(actionFromInt(6, kNumLookActions), std::invalid_argument);
}

TEST_F(TeleportTest, AnOpenTargetIsReachedInOneCountedStep) {
  EpisodeState episode;
  episode.agent = standing(1.0f, 1.0f, 0.0f);
  const Vec3f from = episode.agent.position;
  const StepResult result = teleportEpisode(navmesh(), TaskConfig{}, episode,
                                            target(1.0f, 5.0f, 2.0f));
  // snapped onto the floor below the target, facing its heading
  EXPECT_NEAR(episode.agent.position.x(), 1.0f, 1e-3f);
  EXPECT_NEAR(episode.agent.position.z(), 5.0f, 1e-3f);
  EXPECT_TRUE(navmesh().isNavigable(episode.agent.position));
  EXPECT_FLOAT_EQ(episode.agent.heading, 2.0f);
  EXPECT_EQ(episode.steps, 1);
  EXPECT_FALSE(episode.done);
  EXPECT_FALSE(episode.called_stop);
  EXPECT_FALSE(result.collided);
  EXPECT_FALSE(episode.last_collided);
  // the straight segment, whatever lies between
  EXPECT_NEAR(result.distance, (episode.agent.position - from).norm(), 1e-5f);
  EXPECT_NEAR(result.distance, 4.0f, 1e-2f);
}

TEST_F(TeleportTest, ATargetBeyondTheWallSnapsToTheNearestFloor) {
  const AgentState from = standing(1.0f, 3.0f, 0.0f);
  // 0.3 m beyond the west wall (x = 0): the floor's edge is within the
  // snap's 0.5 m
  const Teleport t =
      resolveTeleport(navmesh(), from, target(-0.3f, 3.0f, 1.0f));
  EXPECT_FALSE(t.refused);
  EXPECT_GT(t.end.position.x(), 0.0f);
  EXPECT_LT(t.end.position.x(), 0.5f);
  EXPECT_NEAR(t.end.position.z(), 3.0f, 1e-2f);
  EXPECT_EQ(navmesh().islandIndex(t.end.position), 0);
}

TEST_F(TeleportTest, AnotherIslandOrNoNavmeshIsRefusedInPlace) {
  const AgentState from = standing(1.0f, 1.0f, 0.0f);
  ASSERT_EQ(navmesh().islandIndex(from.position), 0);
  for (const AgentState& wish :
       {target(3.0f, 3.0f, 1.5f),       // over the table: its top, island 1
        target(1.0f, -2.0f, 1.5f),      // 2 m beyond the north wall
        target(500.0f, 0.0f, 1.5f)}) {  // outside the navmesh's bounds
    const Teleport t = resolveTeleport(navmesh(), from, wish);
    EXPECT_TRUE(t.refused) << wish.position.transpose();
    EXPECT_EQ(t.end.position, from.position);
    EXPECT_FLOAT_EQ(t.end.heading, 1.5f);  // it turns to face its wish
  }
  // a refused teleport is still a step, flagged as a collision
  EpisodeState episode;
  episode.agent = from;
  const StepResult result = teleportEpisode(navmesh(), TaskConfig{}, episode,
                                            target(3.0f, 3.0f, 1.5f));
  EXPECT_TRUE(result.collided);
  EXPECT_TRUE(episode.last_collided);
  EXPECT_EQ(result.distance, 0.0f);
  EXPECT_EQ(episode.steps, 1);
  EXPECT_EQ(episode.agent.position, from.position);
}

TEST_F(TeleportTest, TheStepLimitEndsATeleportingEpisode) {
  EpisodeState episode;
  episode.agent = standing(1.0f, 1.0f, 0.0f);
  TaskConfig task;
  task.max_episode_steps = 3;
  stepEpisode(navmesh(), AgentConfig{}, task, episode, Action::kTurnLeft);
  teleportEpisode(navmesh(), task, episode, target(1.0f, 4.0f, 0.0f));
  EXPECT_FALSE(episode.done);
  teleportEpisode(navmesh(), task, episode, target(5.0f, 4.0f, 0.0f));
  EXPECT_EQ(episode.steps, 3);
  EXPECT_TRUE(episode.done);
  EXPECT_FALSE(episode.called_stop);
  EXPECT_DEATH(
      teleportEpisode(navmesh(), task, episode, target(1.0f, 1.0f, 0.0f)),
      "episode.done");
}

TEST_F(TeleportTest, BadTargetsAndTargetlessTeleportsThrow) {
  const AgentState from = standing(1.0f, 1.0f, 0.0f);
  EXPECT_THAT(
      [&] { resolveTeleport(navmesh(), from, target(NAN, 1.0f, 0.0f)); },
      ::testing::ThrowsMessage<std::invalid_argument>(
          HasSubstr("resolveTeleport(): target pose must be finite")));
  EXPECT_THAT(
      [&] { resolveTeleport(navmesh(), from, target(1.0f, 1.0f, INFINITY)); },
      ::testing::ThrowsMessage<std::invalid_argument>(
          HasSubstr("target pose must be finite")));
  AgentState state = from;
  EXPECT_THAT(
      [&] { applyAction(navmesh(), AgentConfig{}, state, Action::kTeleport); },
      ::testing::ThrowsMessage<std::invalid_argument>(
          HasSubstr("TELEPORT needs a target pose")));
}

}  // namespace
}  // namespace vln::sim
