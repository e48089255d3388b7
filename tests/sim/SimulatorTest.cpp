// Tests src/sim/Simulator.cpp: start snapping, sensor placement, observation
// buffers and post-processing, actions and episode bookkeeping, on a room
// built in code with a known layout.

#include "sim/Simulator.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>

#include "common/Config.h"
#include "sim/Mesh.h"
#include "sim/Renderer.h"
#include "sim/SimTestScenes.h"
#include "sim/SimTestSuites.h"
#include "support/TestPaths.h"

namespace vln::sim {
namespace {

using ::testing::HasSubstr;

// A closed 6 m x 6 m room, floor y = 0, ceiling y = 2.7, walls at x, z =
// +-3, and a 1 m cube (object 4) centred at (2, 0.5, 0).
std::shared_ptr<const Scene> testScene() {
  return test::roomWithCube("test-room", /*ceiling=*/true);
}

SimConfig smallConfig() {
  SimConfig config;
  config.rgb = {32, 32, 90.0f, 1.25f};
  config.depth.camera = {32, 32, 90.0f, 1.25f};
  return config;
}

class SimulatorTest : public test::SceneSuite<testScene> {};

TEST_F(SimulatorTest, ResetSnapsStartToNavmesh) {
  Simulator sim(scene_, smallConfig(), TaskConfig{});
  sim.reset({Vec3f(-1.0f, 0.3f, 1.0f), 0.4f});
  const AgentState& agent = sim.episode().agent;
  EXPECT_NEAR(agent.position.x(), -1.0f, 0.01f);
  EXPECT_NEAR(agent.position.z(), 1.0f, 0.01f);
  // the navmesh lies within a voxel height of the floor
  EXPECT_NEAR(agent.position.y(), 0.0f, 0.2f);
  EXPECT_FLOAT_EQ(agent.heading, 0.4f);
  EXPECT_EQ(sim.episode().steps, 0);
  EXPECT_FALSE(sim.episode().done);
}

TEST_F(SimulatorTest, ResetRejectsStartsAwayFromNavigableSpace) {
  Simulator sim(scene_, smallConfig(), TaskConfig{});
  for (const Vec3f& bad : {Vec3f(0.0f, 1.5f, 0.0f),     // 1.5 m above the floor
                           Vec3f(10.0f, 0.0f, 0.0f),    // outside the room
                           Vec3f(2.0f, 0.0f, 0.0f)}) {  // inside the cube
    try {
      sim.reset({bad, 0.0f});
      FAIL() << "expected std::invalid_argument for " << bad.transpose();
    } catch (const std::invalid_argument& e) {
      EXPECT_THAT(e.what(), HasSubstr("Simulator::reset()"));
      EXPECT_THAT(e.what(), HasSubstr("test-room"));
      EXPECT_THAT(e.what(), HasSubstr("navigable"));
    }
  }
  EXPECT_THROW(sim.reset({Vec3f(NAN, 0, 0), 0.0f}), std::invalid_argument);
  // a heading that is not finite, at an otherwise good start
  for (float heading : {NAN, -INFINITY})
    EXPECT_THAT(
        [&] {
          sim.reset({Vec3f(-1.0f, 0.0f, 1.0f), heading});
        },
        ::testing::ThrowsMessage<std::invalid_argument>(
            HasSubstr("start must be finite")));
  // far outside the scene: refused before the navmesh is asked
  EXPECT_THAT(
      [&] {
        sim.reset({Vec3f(1e30f, 0, 0), 0.0f});
      },
      ::testing::ThrowsMessage<std::invalid_argument>(
          ::testing::AllOf(HasSubstr("Simulator::reset(): scene 'test-room'"),
                           HasSubstr("outside the scene"))));
}

TEST_F(SimulatorTest, ObservationComesFromCameraAtSensorHeight) {
  SimConfig config = smallConfig();
  Simulator sim(scene_, config, TaskConfig{});
  // facing -Z from z = 1: the wall at z = -3 is 4 m ahead
  sim.reset({Vec3f(-1.0f, 0.0f, 1.0f), 0.0f});
  Observation obs;
  sim.observe(obs);
  ASSERT_EQ(obs.rgb_width, 32);
  ASSERT_EQ(obs.rgb_height, 32);
  ASSERT_EQ(obs.rgb.size(), 32u * 32u * 3u);
  ASSERT_EQ(obs.depth.size(), 32u * 32u);
  // centre rows look straight ahead (normalised by max_depth 10)
  const float centre = obs.depth[15 * 32 + 15];
  EXPECT_NEAR(centre, 0.4f, 0.002f);
  for (float d : obs.depth) {
    ASSERT_GE(d, 0.0f);
    ASSERT_LE(d, 1.0f);
  }

  // identical to rendering the scene directly at eye = feet + position_y
  const Vec3f feet = sim.episode().agent.position;
  auto renderer = createRenderer(scene_->mesh(), scene_->rayTracer(),
                                 RendererBackend::kEmbree);
  const CameraPose pose{feet + Vec3f(0, 1.25f, 0), 0.0f, 0.0f};
  std::vector<uint8_t> rgb(32 * 32 * 3);
  std::vector<float> depth(32 * 32);
  renderer->renderRgbDepth(pose, {32, 32, 90.0f}, rgb, depth);
  postprocessDepth(config.depth, depth);
  EXPECT_EQ(obs.rgb, rgb);
  EXPECT_EQ(obs.depth, depth);

  // the bottom row sees the floor (y = 0) from feet.y + 1.25 m (the navmesh
  // may lie up to a voxel above the floor): z-depth = height / -dir.y for a
  // ray whose optical-axis component is 1
  const Vec3f bottom = pixelDirection({32, 32, 90.0f}, 15.5f, 31.0f);
  const float expected = (feet.y() + 1.25f) / -bottom.y() / 10.0f;
  EXPECT_NEAR(obs.depth[31 * 32 + 15], expected, 0.01f);
}

TEST_F(SimulatorTest, SeparateRgbAndDepthCameras) {
  SimConfig config = smallConfig();
  config.rgb = {40, 30, 90.0f, 1.0f};
  config.depth.camera = {16, 12, 60.0f, 1.5f};
  config.depth.normalize_depth = false;
  config.depth.max_depth = 3.5f;
  Simulator sim(scene_, config, TaskConfig{});
  sim.reset({Vec3f(-1.0f, 0.0f, 1.0f), 0.0f});
  Observation obs;
  sim.observe(obs);
  EXPECT_EQ(obs.rgb_width, 40);
  EXPECT_EQ(obs.rgb_height, 30);
  EXPECT_EQ(obs.rgb.size(), 40u * 30u * 3u);
  EXPECT_EQ(obs.depth_width, 16);
  EXPECT_EQ(obs.depth_height, 12);
  ASSERT_EQ(obs.depth.size(), 16u * 12u);
  // the wall is 4 m away, beyond max_depth 3.5 m: clipped, not normalised
  EXPECT_FLOAT_EQ(obs.depth[6 * 16 + 8], 3.5f);

  const Vec3f feet = sim.episode().agent.position;
  auto renderer = createRenderer(scene_->mesh(), scene_->rayTracer(),
                                 RendererBackend::kEmbree);
  std::vector<float> depth(16 * 12);
  renderer->renderDepth({feet + Vec3f(0, 1.5f, 0), 0.0f, 0.0f}, {16, 12, 60.0f},
                        depth);
  postprocessDepth(config.depth, depth);
  EXPECT_EQ(obs.depth, depth);
  std::vector<uint8_t> rgb(40 * 30 * 3);
  renderer->renderRgb({feet + Vec3f(0, 1.0f, 0), 0.0f, 0.0f}, {40, 30, 90.0f},
                      rgb);
  EXPECT_EQ(obs.rgb, rgb);
}

TEST_F(SimulatorTest, ActionsMoveAndTurnTheAgentAndEndTheEpisode) {
  TaskConfig task;
  task.max_episode_steps = 5;
  Simulator sim(scene_, smallConfig(), task);
  sim.reset({Vec3f(-1.0f, 0.0f, 1.0f), 0.0f});
  const Vec3f start = sim.episode().agent.position;
  StepResult result = sim.step(Action::kMoveForward);
  EXPECT_FALSE(result.collided);
  EXPECT_NEAR(result.distance, 0.25f, 1e-3f);
  EXPECT_NEAR(sim.episode().agent.position.z(), start.z() - 0.25f, 1e-3f);
  sim.step(Action::kTurnLeft);
  EXPECT_NEAR(sim.episode().agent.heading, degToRad(15.0f), 1e-5f);
  sim.step(Action::kTurnRight);
  sim.step(Action::kTurnRight);
  EXPECT_NEAR(sim.episode().agent.heading, degToRad(-15.0f), 1e-5f);
  EXPECT_EQ(sim.episode().steps, 4);
  EXPECT_FALSE(sim.episode().done);
  sim.step(Action::kMoveForward);
  // the step limit ends the episode without STOP
  EXPECT_TRUE(sim.episode().done);
  EXPECT_FALSE(sim.episode().called_stop);

  sim.reset({Vec3f(-1.0f, 0.0f, 1.0f), 0.0f});
  EXPECT_EQ(sim.episode().steps, 0);
  sim.step(Action::kStop);
  EXPECT_TRUE(sim.episode().done);
  EXPECT_TRUE(sim.episode().called_stop);
}

TEST_F(SimulatorTest, WalkingIntoTheCubeCollides) {
  Simulator sim(scene_, smallConfig(), TaskConfig{});
  // face +X (heading -90 deg) towards the cube at x = 1.5
  sim.reset({Vec3f(0.0f, 0.0f, 0.0f), -kPi / 2});
  bool collided = false;
  for (int i = 0; i < 12 && !collided; ++i)
    collided = sim.step(Action::kMoveForward).collided;
  EXPECT_TRUE(collided);
  EXPECT_TRUE(sim.episode().last_collided);
  // the agent (radius 0.1) stops at the cube's face
  EXPECT_LT(sim.episode().agent.position.x(), 1.5f);
  EXPECT_GT(sim.episode().agent.position.x(), 1.0f);
}

TEST_F(SimulatorTest, SemanticObservationSeesTheCube) {
  Simulator sim(scene_, smallConfig(), TaskConfig{});
  sim.reset({Vec3f(0.0f, 0.0f, 0.0f), -kPi / 2});
  std::vector<int32_t> ids;
  sim.observeSemantic(ids);
  ASSERT_EQ(ids.size(), 32u * 32u);
  // the cube top (1 m) is below the camera (1.25 m): it fills the lower
  // centre of the image, walls and floor carry no object
  EXPECT_EQ(ids[24 * 32 + 16], 4);
  EXPECT_EQ(ids[4 * 32 + 16], -1);
}

TEST_F(SimulatorTest, BothBackendsGiveNearlyEqualObservations) {
  SimConfig embreeConfig = smallConfig();
  SimConfig osmesaConfig = smallConfig();
  osmesaConfig.renderer = RendererBackend::kOsMesa;
  Simulator a(scene_, embreeConfig, TaskConfig{});
  Simulator b(scene_, osmesaConfig, TaskConfig{});
  const AgentState start{Vec3f(-1.5f, 0.0f, 1.5f), 0.9f};
  a.reset(start);
  b.reset(start);
  Observation oa;
  Observation ob;
  a.observe(oa);
  b.observe(ob);
  int close = 0;
  for (size_t p = 0; p < oa.depth.size(); ++p)
    if (std::abs(oa.depth[p] - ob.depth[p]) < 0.005f) ++close;
  EXPECT_GE(close, static_cast<int>(oa.depth.size()) * 98 / 100);
}

TEST_F(SimulatorTest, SetSceneRequiresANewEpisode) {
  // Embree's worker threads are running: re-execute instead of forking
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  Simulator sim(scene_, smallConfig(), TaskConfig{});
  sim.reset({Vec3f(-1.0f, 0.0f, 1.0f), 0.0f});
  sim.setScene(scene_);
  EXPECT_EQ(sim.scenePtr(), scene_);
  EXPECT_DEATH(sim.step(Action::kMoveForward), "hasEpisode_");
  sim.reset({Vec3f(-1.0f, 0.0f, 1.0f), 0.0f});
  EXPECT_NO_THROW(sim.step(Action::kMoveForward));
}

TEST_F(SimulatorTest, RejectsBadConfig) {
  SimConfig config = smallConfig();
  config.rgb.width = 0;
  try {
    Simulator sim(scene_, config, TaskConfig{});
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("rgb.width"));
  }
  config = smallConfig();
  config.depth.min_depth = 5.0f;
  config.depth.max_depth = 2.0f;
  EXPECT_THROW(Simulator(scene_, config, TaskConfig{}), std::invalid_argument);
  EXPECT_THROW(Simulator(nullptr, smallConfig(), TaskConfig{}),
               std::invalid_argument);
}

// ---------------------------------------------------------------------------
// a pitched camera (RxR's action space)
// ---------------------------------------------------------------------------

// RxR-Habitat's camera height and look actions on an odd-sized image, whose
// middle pixel (16, 16) lies on the optical axis; raw depth in metres.
SimConfig lookConfig(RendererBackend backend) {
  SimConfig config;
  config.rgb = {33, 33, 90.0f, 0.88f};
  config.depth.camera = config.rgb;
  config.depth.normalize_depth = false;
  config.depth.max_depth = 10.0f;
  config.agent.look_actions = true;
  config.agent.tilt_angle = 30.0f;
  config.renderer = backend;
  return config;
}

TEST_F(SimulatorTest, PitchedCameraSeesFloorAndCeilingAtHandComputedDepths) {
  for (RendererBackend backend :
       {RendererBackend::kEmbree, RendererBackend::kOsMesa, RendererBackend::kRaster}) {
    SCOPED_TRACE(rendererBackendName(backend));
    const CameraIntrinsics camera{33, 33, 90.0f};
    Simulator sim(scene_, lookConfig(backend), TaskConfig{});
    // facing -Z from z = 1: level, the wall at z = -3 is 4 m ahead
    sim.reset({Vec3f(-1.0f, 0.0f, 1.0f), 0.0f});
    // the eye is 0.88 m above the navmesh, which may lie up to a voxel
    // above the floor (y = 0)
    const float eyeY = sim.episode().agent.position.y() + 0.88f;
    Observation obs;
    sim.observe(obs);
    EXPECT_NEAR(obs.depth[16 * 33 + 16], 4.0f, 0.01f);

    // LOOK_DOWN 30 degrees: the optical axis meets the floor eyeY /
    // sin(30) = 2 eyeY away (1.52 m ahead, clear of the cube and walls),
    // and that distance is the z-depth of the middle pixel
    sim.step(Action::kLookDown);
    EXPECT_NEAR(sim.episode().agent.pitch, degToRad(-30.0f), 1e-6f);
    sim.observe(obs);
    EXPECT_NEAR(obs.depth[16 * 33 + 16], 2.0f * eyeY, 0.01f);
    // off the axis the depth stays the distance along the optical axis
    // (Habitat's depth sensor), not the ray's length: the camera-frame ray
    // (0, y, -1) of row 28 points along (0, cos30 y - sin30, ...) in the
    // world (Rx(-30 deg)), so it reaches the floor at z-depth eyeY / -that
    const float y = pixelDirection(camera, 16.0f, 28.0f).y();
    const float down = std::cos(degToRad(30.0f)) * y - 0.5f;
    EXPECT_NEAR(obs.depth[28 * 33 + 16], eyeY / -down, 0.01f);
    // the ray itself is longer by |(0, y, -1)|: not what is reported
    EXPECT_GT(eyeY / -down * std::sqrt(1.0f + y * y) - obs.depth[28 * 33 + 16],
              0.05f);

    // LOOK_UP twice: 30 degrees up, the ceiling (y = 2.7) is
    // (2.7 - eyeY) / sin(30) away along the axis (3.15 m ahead, short of
    // the wall at 4 m)
    sim.step(Action::kLookUp);
    sim.step(Action::kLookUp);
    EXPECT_NEAR(sim.episode().agent.pitch, degToRad(30.0f), 1e-6f);
    sim.observe(obs);
    EXPECT_NEAR(obs.depth[16 * 33 + 16], 2.0f * (2.7f - eyeY), 0.01f);
    // the looks moved nothing but the camera
    EXPECT_EQ(sim.episode().agent.heading, 0.0f);
    EXPECT_EQ(sim.episode().steps, 3);
  }
}

TEST_F(SimulatorTest, PitchedObservationIsTheRendererAtThatPitch) {
  // Simulator hands the agent's pitch to the renderer unchanged
  SimConfig config = lookConfig(RendererBackend::kEmbree);
  Simulator sim(scene_, config, TaskConfig{});
  sim.reset({Vec3f(-1.5f, 0.0f, 1.5f), 0.9f});
  sim.step(Action::kLookDown);
  Observation obs;
  sim.observe(obs);
  auto renderer = createRenderer(scene_->mesh(), scene_->rayTracer(),
                                 RendererBackend::kEmbree);
  const AgentState& agent = sim.episode().agent;
  const CameraPose pose{agent.position + Vec3f(0, 0.88f, 0), 0.9f,
                        degToRad(-30.0f)};
  std::vector<uint8_t> rgb(33 * 33 * 3);
  std::vector<float> depth(33 * 33);
  renderer->renderRgbDepth(pose, {33, 33, 90.0f}, rgb, depth);
  postprocessDepth(config.depth, depth);
  EXPECT_EQ(obs.rgb, rgb);
  EXPECT_EQ(obs.depth, depth);
}

TEST_F(SimulatorTest, ResetRestoresAPitchedStateExactly) {
  // a state taken mid-episode (resume, dumps) and given to reset() again
  // gives the same state and the same view
  const SimConfig config = lookConfig(RendererBackend::kEmbree);
  Simulator first(scene_, config, TaskConfig{});
  first.reset({Vec3f(-1.0f, 0.0f, 1.0f), 0.3f});
  for (Action a : {Action::kMoveForward, Action::kLookDown, Action::kTurnLeft,
                   Action::kLookDown, Action::kMoveForward})
    first.step(a);
  const AgentState saved = first.episode().agent;
  EXPECT_NEAR(saved.pitch, degToRad(-60.0f), 1e-6f);

  Simulator second(scene_, config, TaskConfig{});
  second.reset(saved);
  EXPECT_EQ(second.episode().agent, saved);
  Observation a;
  Observation b;
  first.observe(a);
  second.observe(b);
  EXPECT_EQ(a.rgb, b.rgb);
  EXPECT_EQ(a.depth, b.depth);

  // a dataset start (no pitch given) is level; a pitch that is not finite
  // is refused, and one beyond pi is wrapped
  second.reset({saved.position, saved.heading});
  EXPECT_EQ(second.episode().agent.pitch, 0.0f);
  EXPECT_THAT(
      [&] {
        second.reset({saved.position, 0.0f, NAN});
      },
      ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("pitch nan")));
  second.reset({saved.position, 0.0f, degToRad(210.0f)});
  EXPECT_NEAR(second.episode().agent.pitch, degToRad(-150.0f), 1e-5f);
}

TEST_F(SimulatorTest, R2rEpisodesAreUnchangedByTheLookActions) {
  // the R2R actions give the same states and images whether or not the
  // RxR action space is enabled
  SimConfig r2r = smallConfig();
  SimConfig rxr = r2r;
  rxr.agent.look_actions = true;
  Simulator a(scene_, r2r, TaskConfig{});
  Simulator b(scene_, rxr, TaskConfig{});
  a.reset({Vec3f(-1.0f, 0.0f, 1.0f), 0.2f});
  b.reset({Vec3f(-1.0f, 0.0f, 1.0f), 0.2f});
  Observation oa;
  Observation ob;
  for (Action action : {Action::kMoveForward, Action::kTurnRight,
                        Action::kMoveForward, Action::kTurnLeft}) {
    a.step(action);
    b.step(action);
    EXPECT_EQ(a.episode().agent, b.episode().agent);
    a.observe(oa);
    b.observe(ob);
    EXPECT_EQ(oa.rgb, ob.rgb);
    EXPECT_EQ(oa.depth, ob.depth);
  }
  // and the R2R simulator refuses the looks
  EXPECT_THAT([&] { a.step(Action::kLookUp); },
              ::testing::ThrowsMessage<std::invalid_argument>(
                  HasSubstr("look_actions")));
}

TEST(RxrTaskConfigTest, HoldsRxrHabitatsSettingsAndRuns) {
  // configs/rxr/task.yaml: VLN-CE's rxr_vlnce_english_task.yaml settings
  SimConfig sim;
  TaskConfig task;
  const auto file = test::sourcePath() / "configs" / "rxr" / "task.yaml";
  common::readConfigFileSection(file, "sim", {}, [&](common::ConfigVisitor& v) {
    v.section("sim", sim, "Simulator");
  });
  common::readConfigFileSection(
      file, "task", {},
      [&](common::ConfigVisitor& v) { v.section("task", task, "Task"); });
  EXPECT_EQ(sim.agent.forward_step_size, 0.25f);
  EXPECT_EQ(sim.agent.turn_angle, 30.0f);
  EXPECT_FALSE(sim.agent.allow_sliding);
  EXPECT_TRUE(sim.agent.look_actions);
  EXPECT_EQ(sim.agent.tilt_angle, 30.0f);
  EXPECT_EQ(numActions(sim.agent), 6);
  EXPECT_EQ(sim.navmesh.agent_radius, 0.18f);
  EXPECT_EQ(sim.navmesh.agent_height, 0.88f);
  for (const CameraConfig& camera : {sim.rgb, sim.depth.camera})
    EXPECT_EQ(camera, (CameraConfig{640, 480, 79.0f, 0.88f}));
  EXPECT_EQ(sim.depth.min_depth, 0.5f);
  EXPECT_EQ(sim.depth.max_depth, 5.0f);
  EXPECT_TRUE(sim.depth.normalize_depth);
  EXPECT_EQ(task.max_episode_steps, 500);
  EXPECT_EQ(task.success_distance, 3.0f);
  // the rest stays R2R's
  const SimConfig r2r;
  SimConfig rest = sim;
  rest.agent = r2r.agent;
  rest.navmesh = r2r.navmesh;
  rest.rgb = r2r.rgb;
  rest.depth = r2r.depth;
  EXPECT_EQ(rest, r2r);

  // an episode on a room whose navmesh is built for RxR's agent: the six
  // actions, 640x480 images, in one rendering pass
  const auto scene =
      Scene::fromMesh("rxr-room", test::roomWithCube("rxr-room", true)->mesh(),
                      {}, sim.navmesh);
  Simulator simulator(scene, sim, task);
  simulator.reset({Vec3f(-1.0f, 0.0f, 1.0f), 0.0f});
  Observation obs;
  for (Action a : {Action::kLookDown, Action::kMoveForward, Action::kTurnLeft,
                   Action::kLookUp, Action::kTurnRight, Action::kStop}) {
    simulator.step(a);
    simulator.observe(obs);
  }
  EXPECT_TRUE(simulator.episode().called_stop);
  EXPECT_EQ(simulator.episode().steps, 6);
  EXPECT_EQ(simulator.episode().agent.pitch, 0.0f);
  EXPECT_EQ(obs.rgb.size(), 640u * 480u * 3u);
  EXPECT_EQ(obs.depth.size(), 640u * 480u);
  // level again and facing the wall at z = -3 from z = 0.75 (one 0.25 m
  // step): z-depth 3.75 m everywhere on it, normalised from [0.5, 5] m
  EXPECT_NEAR(obs.depth[240 * 640 + 320], (3.75f - 0.5f) / 4.5f, 0.01f);
}

}  // namespace
}  // namespace vln::sim
