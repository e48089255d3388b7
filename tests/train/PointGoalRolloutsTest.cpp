// The point-goal episodes of the depth pretraining: the goal sensor's frame
// and signs, episode sampling, and rollouts on the episode scheduler (the
// follower reaches its goals; outcomes do not depend on the environments).

#include "train/PointGoalRollouts.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <set>

#include "train/PretrainTasks.h"
#include "train/PretrainTestUtil.h"

namespace vln::train {
namespace {

using ::testing::HasSubstr;

// two small pretraining houses (seeds 4242 and 4243) at 32x32
ExperimentConfig houseConfig() {
  ExperimentConfig c = test::tinyPretrainConfig("depth_pointnav", "unused");
  c.pretrain.train_houses = 2;
  c.pretrain.heldout_houses = 1;
  c.pretrain.house_seed = 4242;
  c.pretrain.success_distance = 0.3f;
  c.task.max_episode_steps = 80;
  return c;
}

const std::vector<std::shared_ptr<const sim::Scene>>& tinyHouses() {
  static const auto houses = generatePretrainHouses(houseConfig(), 2).train;
  return houses;
}

TEST(PointGoalObservationTest, PolarCoordinatesInTheAgentFrame) {
  sim::AgentState agent;  // at the origin, looking along -Z
  auto g = pointGoalObservation(agent, Vec3f(0.0f, 0.0f, -2.0f));
  EXPECT_NEAR(g[0], 2.0f, 1e-6f);  // straight ahead
  EXPECT_NEAR(g[1], 1.0f, 1e-6f);
  EXPECT_NEAR(g[2], 0.0f, 1e-6f);
  // heading +90 degrees looks along -X (common/Math.h), so -X is on the left
  g = pointGoalObservation(agent, Vec3f(-1.0f, 0.0f, 0.0f));
  EXPECT_NEAR(g[0], 1.0f, 1e-6f);
  EXPECT_NEAR(g[1], 0.0f, 1e-6f);
  EXPECT_NEAR(g[2], 1.0f, 1e-6f);
  g = pointGoalObservation(agent, Vec3f(1.0f, 0.0f, 0.0f));
  EXPECT_NEAR(g[2], -1.0f, 1e-6f);
  // the height difference does not count; a turned agent sees it ahead
  agent.heading = kPi / 2.0f;
  agent.position = Vec3f(1.0f, 0.3f, 5.0f);
  g = pointGoalObservation(agent, Vec3f(-2.0f, 0.0f, 5.0f));
  EXPECT_NEAR(g[0], 3.0f, 1e-5f);
  EXPECT_NEAR(g[1], 1.0f, 1e-5f);
  EXPECT_NEAR(g[2], 0.0f, 1e-5f);
  // behind: cos = -1
  g = pointGoalObservation(agent, Vec3f(4.0f, 0.0f, 5.0f));
  EXPECT_NEAR(g[1], -1.0f, 1e-5f);
}

TEST(PointGoalEpisodesTest, InRangeOnTheMainIslandAndDeterministic) {
  const auto& scenes = tinyHouses();
  const auto a = samplePointGoalEpisodes(scenes, 20, 1.0f, 4.0f, /*seed=*/5);
  const auto b = samplePointGoalEpisodes(scenes, 25, 1.0f, 4.0f, /*seed=*/5);
  ASSERT_EQ(a.size(), 20u);
  std::set<int> housesSeen;
  for (size_t k = 0; k < a.size(); ++k) {
    const auto& e = a[k];
    housesSeen.insert(e.house);
    const sim::NavMesh& navmesh =
        scenes[static_cast<size_t>(e.house)]->navmesh();
    EXPECT_GE(e.geodesic_distance, 1.0f);
    EXPECT_LE(e.geodesic_distance, 4.0f);
    EXPECT_NEAR(navmesh.geodesicDistance(e.start.position, e.goal),
                e.geodesic_distance, 1e-4f);
    EXPECT_EQ(navmesh.islandIndex(e.start.position), 0);
    EXPECT_EQ(navmesh.islandIndex(e.goal), 0);
    // episode k does not depend on how many are drawn
    EXPECT_EQ(b[k].start, e.start);
    EXPECT_EQ(b[k].goal, e.goal);
  }
  EXPECT_EQ(housesSeen.size(), 2u);
  EXPECT_NE(samplePointGoalEpisodes(scenes, 1, 1.0f, 4.0f, 6)[0].goal,
            a[0].goal);
}

TEST(PointGoalEpisodesTest, ImpossibleRangeNamesTheScene) {
  const auto& scenes = tinyHouses();
  try {
    samplePointGoalEpisodes(scenes, 1, 400.0f, 500.0f, 1);
    FAIL() << "no house is 400 m across";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("house_4242"));
    EXPECT_THAT(e.what(), HasSubstr("pretrain.min_goal_distance"));
  }
}

TEST(PointGoalRolloutsTest, TheFollowerArrivesWhateverTheEnvironments) {
  const auto& scenes = tinyHouses();
  const auto episodes = samplePointGoalEpisodes(scenes, 12, 1.0f, 4.0f, 3);
  RolloutSpec follower;
  follower.driver = Driver::kOracle;
  ExperimentConfig c = houseConfig();
  c.trainer.num_envs = 4;
  const auto outcomes = runPointGoalEpisodes(c, scenes, episodes, follower,
                                             torch::kCPU, "follower");
  ASSERT_EQ(outcomes.size(), episodes.size());
  int successes = 0;
  for (size_t k = 0; k < outcomes.size(); ++k) {
    successes += outcomes[k].success;
    EXPECT_GE(outcomes[k].path, episodes[k].geodesic_distance - 0.3);
  }
  EXPECT_GE(successes, 11);

  // the random agent with recording: the same steps and outcomes on one
  // environment and one thread as on five environments and two threads
  RolloutSpec random;
  random.driver = Driver::kRandom;
  random.seed = 17;
  std::vector<RecordedEpisode> recordedA, recordedB;
  random.record = &recordedA;
  random.byteBudget = size_t{1} << 30;
  c.trainer.num_envs = 1;
  c.trainer.env_threads = 1;
  const auto a =
      runPointGoalEpisodes(c, scenes, episodes, random, torch::kCPU, "a");
  random.record = &recordedB;
  c.trainer.num_envs = 5;
  c.trainer.env_threads = 2;
  const auto b =
      runPointGoalEpisodes(c, scenes, episodes, random, torch::kCPU, "b");
  for (size_t k = 0; k < episodes.size(); ++k) {
    EXPECT_EQ(a[k].steps, b[k].steps) << k;
    EXPECT_EQ(a[k].path, b[k].path) << k;
    EXPECT_EQ(recordedA[k].label, recordedB[k].label) << k;
    EXPECT_EQ(recordedA[k].depth, recordedB[k].depth) << k;
    EXPECT_EQ(recordedA[k].length(), a[k].steps) << k;
  }

  // recording beyond the budget is an error naming the bound
  random.byteBudget = 1000;
  EXPECT_THAT(
      [&] {
        runPointGoalEpisodes(c, scenes, episodes, random, torch::kCPU, "c");
      },
      ::testing::Throws<std::runtime_error>(::testing::Property(
          &std::exception::what, HasSubstr("pretrain.max_memory_gib"))));
}

}  // namespace
}  // namespace vln::train
