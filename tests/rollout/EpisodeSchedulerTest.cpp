// runEpisodes(): the order in which episodes meet environments, the hooks
// and what they see, on a 6 m room with a job whose episodes STOP after a
// scripted number of turns.

#include "rollout/EpisodeScheduler.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "sim/SimTestScenes.h"

namespace vln::rollout {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;

// Episode i turns left turns[i] times, then STOPs; every hook call is
// written to `trace`.
class TurnThenStopJob : public EpisodeJob {
 public:
  TurnThenStopJob(VectorEnv& envs, std::vector<int> turns)
      : envs_(envs), turns_(std::move(turns)) {
    scene_ = test::roomWithCube("room", /*ceiling=*/true);
  }
  EpisodeStart startOf(int index) override {
    trace.push_back("start " + std::to_string(index));
    EpisodeStart start;
    start.scene = scene_;
    start.agent.position = Vec3f(-1.0f, 0.0f, 0.2f * static_cast<float>(index));
    return start;
  }
  void started(const EnvBatch& batch) override {
    for (size_t k = 0; k < batch.size(); ++k) {
      trace.push_back("env " + std::to_string(batch.envs[k]) + " <- " +
                      std::to_string(batch.episodes[k]));
      EXPECT_EQ(envs_.state(batch.envs[k]).steps, 0);
      rendered.push_back(!envs_.observation(batch.envs[k]).rgb.empty());
    }
  }
  std::vector<sim::Action> act(const EnvBatch& running) override {
    std::string line = "act";
    std::vector<sim::Action> actions;
    for (size_t k = 0; k < running.size(); ++k) {
      line += " " + std::to_string(running.envs[k]) + ":" +
              std::to_string(running.episodes[k]);
      const int done = envs_.state(running.envs[k]).steps;
      actions.push_back(done < turns_[static_cast<size_t>(running.episodes[k])]
                            ? sim::Action::kTurnLeft
                            : sim::Action::kStop);
    }
    trace.push_back(line);
    return actions;
  }
  void stepped(const EnvBatch& running, std::span<const sim::Action> actions,
               std::span<const sim::StepResult> results) override {
    EXPECT_EQ(actions.size(), running.size());
    EXPECT_EQ(results.size(), running.size());
    steps += static_cast<int>(running.size());
  }
  void finished(const EnvBatch& ended) override {
    std::string line = "finish";
    for (size_t k = 0; k < ended.size(); ++k) {
      EXPECT_TRUE(envs_.state(ended.envs[k]).called_stop);
      line += " " + std::to_string(ended.envs[k]) + ":" +
              std::to_string(ended.episodes[k]);
    }
    trace.push_back(line);
  }

  std::vector<std::string> trace;
  std::vector<bool> rendered;
  int steps = 0;

 private:
  VectorEnv& envs_;
  std::vector<int> turns_;
  std::shared_ptr<const sim::Scene> scene_;
};

sim::SimConfig smallCameras() {
  sim::SimConfig sim;
  sim.rgb = {16, 16, 90.0f, 1.25f};
  sim.depth.camera = {16, 16, 90.0f, 1.25f};
  return sim;
}

std::vector<std::string> runTrace(int numEnvs, int threads,
                                  const std::vector<int>& turns, bool render,
                                  RolloutCounts* counts = nullptr,
                                  std::vector<bool>* rendered = nullptr) {
  VectorEnv envs(numEnvs, smallCameras(), sim::TaskConfig{}, nullptr, threads);
  TurnThenStopJob job(envs, turns);
  const RolloutCounts c =
      runEpisodes(envs, static_cast<int>(turns.size()), job, render);
  EXPECT_EQ(job.steps, c.steps);
  if (counts) *counts = c;
  if (rendered) *rendered = job.rendered;
  return job.trace;
}

TEST(EpisodeSchedulerTest, EpisodesFillTheLowestIdleEnvironmentsInOrder) {
  // episode i takes turns[i] + 1 actions (the turns, then STOP)
  RolloutCounts counts;
  const std::vector<std::string> trace =
      runTrace(/*numEnvs=*/3, /*threads=*/2, {2, 0, 1, 0, 3}, false, &counts);
  EXPECT_THAT(
      trace,
      ElementsAre(
          "start 0", "start 1", "start 2", "env 0 <- 0", "env 1 <- 1",
          "env 2 <- 2", "act 0:0 1:1 2:2",
          "finish 1:1",  // episode 1 STOPs at once
          "start 3", "env 1 <- 3", "act 0:0 1:3 2:2",
          "finish 1:3 2:2",  // both STOP at this step, in environment order
          "start 4", "env 1 <- 4",
          "act 0:0 1:4",  // environment 2 stays idle: nothing is pending
          "finish 0:0", "act 1:4", "act 1:4", "act 1:4", "finish 1:4"));
  EXPECT_EQ(counts.episodes, 5);
  EXPECT_EQ(counts.steps, 3 + 1 + 2 + 1 + 4);
}

TEST(EpisodeSchedulerTest, TheOrderDependsOnTheEnvironmentCountOnly) {
  const std::vector<int> turns = {4, 1, 0, 2, 5, 0, 1, 3, 2};
  for (int numEnvs : {1, 2, 4}) {
    const auto reference = runTrace(numEnvs, 1, turns, false);
    EXPECT_EQ(runTrace(numEnvs, 3, turns, false), reference) << numEnvs;
    EXPECT_EQ(runTrace(numEnvs, 2, turns, true), reference) << numEnvs;
  }
}

TEST(EpisodeSchedulerTest, MoreEnvironmentsThanEpisodesLeavesTheRestIdle) {
  RolloutCounts counts;
  EXPECT_THAT(
      runTrace(4, 2, {1}, false, &counts),
      ElementsAre("start 0", "env 0 <- 0", "act 0:0", "act 0:0", "finish 0:0"));
  EXPECT_EQ(counts.episodes, 1);
  EXPECT_EQ(counts.steps, 2);
}

TEST(EpisodeSchedulerTest, NoEpisodesRunsNoHook) {
  RolloutCounts counts{7, 7};
  EXPECT_TRUE(runTrace(2, 1, {}, true, &counts).empty());
  EXPECT_EQ(counts.episodes, 0);
  EXPECT_EQ(counts.steps, 0);
}

TEST(EpisodeSchedulerTest, ObservationsAreRenderedOnlyWhenAsked) {
  std::vector<bool> rendered;
  runTrace(2, 2, {1, 1, 0}, /*render=*/true, nullptr, &rendered);
  EXPECT_THAT(rendered, ElementsAre(true, true, true));
  runTrace(2, 2, {1, 1, 0}, /*render=*/false, nullptr, &rendered);
  EXPECT_THAT(rendered, ElementsAre(false, false, false));
}

// A job that returns one action too few.
class ShortJob : public EpisodeJob {
 public:
  EpisodeStart startOf(int) override {
    EpisodeStart start;
    start.scene = scene;
    return start;
  }
  std::vector<sim::Action> act(const EnvBatch& running) override {
    return std::vector<sim::Action>(running.size() - 1, sim::Action::kStop);
  }
  void finished(const EnvBatch&) override {}
  std::shared_ptr<const sim::Scene> scene = test::roomWithCube("room", false);
};

TEST(EpisodeSchedulerTest, AJobMustChooseOneActionPerEnvironment) {
  VectorEnv envs(2, smallCameras(), sim::TaskConfig{}, nullptr, 1);
  ShortJob job;
  EXPECT_THAT([&] { runEpisodes(envs, 2, job, false); },
              ::testing::Throws<std::invalid_argument>(::testing::Property(
                  &std::exception::what,
                  HasSubstr("chose 1 actions for 2 environments"))));
}

TEST(EpisodeSchedulerTest, AnEpisodeNamedByIdNeedsASceneCache) {
  VectorEnv envs(1, smallCameras(), sim::TaskConfig{}, nullptr, 1);
  data::Episode episode;
  episode.episode_id = 12;
  episode.scene_id = "procedural/h/h.glb";
  const data::Episode* one[] = {&episode};
  const int env[] = {0};
  EXPECT_THAT([&] { envs.reset(env, one); },
              ::testing::Throws<std::invalid_argument>(::testing::Property(
                  &std::exception::what,
                  HasSubstr("episode 12 names its scene by id, but this "
                            "VectorEnv has no scene cache"))));
}

}  // namespace
}  // namespace vln::rollout
