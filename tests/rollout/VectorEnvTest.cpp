#include "rollout/VectorEnv.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "sim/MeshIo.h"
#include "support/TestPaths.h"
#include "world/HouseGenerator.h"

namespace vln::rollout {
namespace {

// A generated house saved as a scene file, and episodes starting in it.
class VectorEnvTest : public ::testing::Test {
 protected:
  void SetUp() override {
    world::HouseConfig house;
    house.min_rooms = 3;
    house.max_rooms = 4;
    auto generated = world::generateHouse(/*seed=*/5, house, "h5");
    sim::saveScene(dir_ / "procedural" / "h5" / "h5.glb", generated.mesh,
                   generated.semantics);
    config_.scenes_dir = dir_.path().string();
    config_.rgb = {32, 32, 90.0f, 1.25f};
    config_.depth.camera = {32, 32, 90.0f, 1.25f};
    auto scene =
        sim::Scene::load(dir_ / "procedural" / "h5" / "h5.glb", config_);
    std::mt19937_64 rng(3);
    for (int i = 0; i < 6; ++i) {
      data::Episode e;
      e.episode_id = i;
      e.scene_id = "procedural/h5/h5.glb";
      e.start_position = scene->navmesh().randomPoint(rng, 0);
      episodes_.push_back(e);
    }
  }
  test::TempDir dir_;
  sim::SimConfig config_;
  std::vector<data::Episode> episodes_;
};

TEST_F(VectorEnvTest, ParallelStepsMatchSerialSteps) {
  auto cache = std::make_shared<SceneCache>(config_);
  VectorEnv parallel(3, config_, sim::TaskConfig{}, cache, 2);
  VectorEnv serial(3, config_, sim::TaskConfig{}, cache, 1);
  std::vector<int> envs = {0, 1, 2};
  std::vector<const data::Episode*> eps = {&episodes_[0], &episodes_[1],
                                           &episodes_[2]};
  parallel.reset(envs, eps);
  serial.reset(envs, eps);
  EXPECT_EQ(cache->loads(), 1);  // one scene shared by six environments
  std::vector<sim::Action> actions = {sim::Action::kMoveForward,
                                      sim::Action::kTurnLeft,
                                      sim::Action::kMoveForward};
  for (int t = 0; t < 10; ++t) {
    parallel.step(envs, actions);
    serial.step(envs, actions);
  }
  for (int env : envs) {
    EXPECT_EQ(parallel.state(env).agent, serial.state(env).agent);
    EXPECT_EQ(parallel.state(env).steps, 10);
    EXPECT_EQ(parallel.observation(env).rgb, serial.observation(env).rgb);
    EXPECT_EQ(parallel.observation(env).depth, serial.observation(env).depth);
    EXPECT_EQ(parallel.episode(env).episode_id, env);
  }
}

TEST_F(VectorEnvTest, ErrorsNameTheEpisodeAndScene) {
  auto cache = std::make_shared<SceneCache>(config_);
  VectorEnv env(1, config_, sim::TaskConfig{}, cache, 1);
  data::Episode missing = episodes_[0];
  missing.scene_id = "procedural/nope/nope.glb";
  std::vector<int> envs = {0};
  std::vector<const data::Episode*> eps = {&missing};
  EXPECT_THAT([&] { env.reset(envs, eps); },
              ::testing::Throws<std::runtime_error>(::testing::Property(
                  &std::exception::what, ::testing::HasSubstr("nope.glb"))));
  data::Episode offMesh = episodes_[0];
  offMesh.start_position = Vec3f(1000.0f, 0.0f, 1000.0f);
  eps = {&offMesh};
  EXPECT_THAT(
      [&] { env.reset(envs, eps); },
      ::testing::Throws<std::invalid_argument>(::testing::Property(
          &std::exception::what,
          ::testing::HasSubstr("episode 0 (scene procedural/h5/h5.glb)"))));
  std::vector<sim::Action> actions = {sim::Action::kStop};
  VectorEnv fresh(1, config_, sim::TaskConfig{}, cache, 1);
  EXPECT_THROW(fresh.step(envs, actions), std::invalid_argument);
}

TEST_F(VectorEnvTest, ARequestedTeleportIsTheNextStep) {
  auto cache = std::make_shared<SceneCache>(config_);
  sim::TaskConfig task;
  task.max_episode_steps = 2;
  VectorEnv envs(2, config_, task, cache, 2);
  const std::vector<int> both = {0, 1};
  std::vector<const data::Episode*> eps = {&episodes_[0], &episodes_[1]};
  envs.reset(both, eps, /*render=*/false);
  // environment 0 teleports to episode 2's start, environment 1 walks
  const sim::AgentState walker = envs.state(1).agent;
  sim::AgentState wish{episodes_[2].start_position, 0.75f, 0.0f};
  envs.requestTeleport(0, wish);
  const std::vector<sim::Action> actions = {sim::Action::kTeleport,
                                            sim::Action::kTurnLeft};
  const auto results = envs.step(both, actions, /*render=*/false);
  EXPECT_FALSE(results[0].collided);
  EXPECT_LT((envs.state(0).agent.position - wish.position).norm(), 1e-3f);
  EXPECT_FLOAT_EQ(envs.state(0).agent.heading, 0.75f);
  EXPECT_EQ(envs.state(0).steps, 1);
  EXPECT_EQ(envs.state(1).agent.position, walker.position);
  EXPECT_EQ(envs.state(1).steps, 1);

  // the request is used up: another TELEPORT needs another request, and a
  // pending request must be taken by the next step
  const std::vector<int> first = {0};
  const std::vector<sim::Action> teleport = {sim::Action::kTeleport};
  EXPECT_THAT([&] { envs.step(first, teleport, false); },
              ::testing::Throws<std::invalid_argument>(::testing::Property(
                  &std::exception::what,
                  ::testing::HasSubstr("TELEPORT without requestTeleport()"))));
  envs.requestTeleport(0, wish);
  const std::vector<sim::Action> forward = {sim::Action::kMoveForward};
  EXPECT_THAT([&] { envs.step(first, forward, false); },
              ::testing::Throws<std::invalid_argument>(::testing::Property(
                  &std::exception::what,
                  ::testing::HasSubstr("requested a teleport but was given "
                                       "MOVE_FORWARD"))));
  // a reset drops it; the second step of a two-step episode ends it
  envs.reset(first, std::vector<const data::Episode*>{&episodes_[0]}, false);
  envs.step(first, forward, false);
  envs.requestTeleport(0, wish);
  envs.step(first, teleport, false);
  EXPECT_EQ(envs.state(0).steps, 2);
  EXPECT_TRUE(envs.state(0).done);
  EXPECT_FALSE(envs.state(0).called_stop);
}

}  // namespace
}  // namespace vln::rollout
