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

}  // namespace
}  // namespace vln::rollout
