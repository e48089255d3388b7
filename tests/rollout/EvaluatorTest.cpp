// evaluateEpisodes() on a small generated house with scripted agents whose
// metrics are known by construction: replaying the follower's ground truth
// succeeds with SPL d0 / max(d0, TL) and reproduces its positions exactly;
// an agent that never stops hits the step limit and fails.

#include "rollout/Evaluator.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <map>
#include <vector>

#include "common/Random.h"
#include "rollout/RolloutTestWorld.h"
#include "rollout/WaypointOracle.h"

namespace vln::rollout {
namespace {

using test::rolloutTestWorld;
using ::testing::HasSubstr;

// Replays the ground-truth actions of each episode; logs its resets.
class ReplayAgent : public Agent {
 public:
  explicit ReplayAgent(const data::GroundTruth& gt) : gt_(gt) {}
  void reset(int env, const data::Episode& episode) override {
    cursor_[env] = {episode.episode_id, 0};
    resets.emplace_back(env, episode.episode_id);
  }
  std::vector<sim::Action> act(VectorEnv& envs,
                               std::span<const int> active) override {
    std::vector<sim::Action> actions;
    for (int env : active) {
      auto& [id, step] = cursor_.at(env);
      EXPECT_EQ(envs.episode(env).episode_id, id);
      // observations are rendered only when an agent reads them
      EXPECT_TRUE(envs.observation(env).rgb.empty());
      actions.push_back(gt_.at(id).actions.at(static_cast<size_t>(step++)));
    }
    return actions;
  }
  bool needsObservations() const override { return false; }
  std::vector<std::pair<int, int>> resets;

 private:
  const data::GroundTruth& gt_;
  std::map<int, std::pair<int, int>> cursor_;
};

// Turns left forever (never STOP); checks it is shown 32x32 observations.
class SpinningAgent : public Agent {
 public:
  void reset(int, const data::Episode&) override {}
  std::vector<sim::Action> act(VectorEnv& envs,
                               std::span<const int> active) override {
    for (int env : active)
      EXPECT_EQ(envs.observation(env).rgb.size(), 32u * 32u * 3u);
    return std::vector<sim::Action>(active.size(), sim::Action::kTurnLeft);
  }
};

// Draws actions from a fixed distribution with a generator seeded by the
// episode id (as the baselines and the policy agents do), so an episode's
// actions do not depend on the environment that runs it.
class RandomWalkAgent : public Agent {
 public:
  RandomWalkAgent(int numEnvs, uint64_t seed)
      : rngs_(static_cast<size_t>(numEnvs)), seed_(seed) {}
  void reset(int env, const data::Episode& episode) override {
    rngs_.at(static_cast<size_t>(env))
        .seed(common::episodeSeed(seed_, std::to_string(episode.episode_id)));
  }
  std::vector<sim::Action> act(VectorEnv&,
                               std::span<const int> active) override {
    // STOP 5%, forward 60%, left 20%, right 15%
    static constexpr double kCumulative[] = {0.05, 0.65, 0.85};
    std::vector<sim::Action> actions;
    for (int env : active) {
      const double u = common::uniform01(rngs_.at(static_cast<size_t>(env)));
      int a = 0;
      while (a < 3 && u >= kCumulative[a]) ++a;
      actions.push_back(sim::actionFromInt(a));
    }
    return actions;
  }
  bool needsObservations() const override { return false; }

 private:
  std::vector<std::mt19937_64> rngs_;
  uint64_t seed_;
};

EvalConfig evalConfig(int numEnvs, int threads) {
  EvalConfig c;
  c.num_envs = numEnvs;
  c.threads = threads;
  return c;
}

EvaluationResult run(Agent& agent, const std::vector<data::Episode>& episodes,
                     const data::GroundTruth* gt, int numEnvs, int threads,
                     const std::function<void(int, int)>& progress = {}) {
  const auto& w = rolloutTestWorld();
  auto cache = std::make_shared<SceneCache>(w.sim);
  VectorEnv envs(numEnvs, w.sim, w.task, cache, threads);
  return evaluateEpisodes(agent, envs, episodes, gt,
                          evalConfig(numEnvs, threads), progress);
}

TEST(EvaluatorTest, ReplayingTheGroundTruthSucceedsWithTheFollowersPath) {
  const auto& w = rolloutTestWorld();
  ReplayAgent agent(w.groundTruth);
  std::vector<std::pair<int, int>> progress;
  const EvaluationResult r =
      run(agent, w.episodes, &w.groundTruth, /*numEnvs=*/3,
          /*threads=*/2,
          [&](int done, int total) { progress.emplace_back(done, total); });
  ASSERT_EQ(r.episodes.size(), w.episodes.size());
  for (size_t i = 0; i < w.episodes.size(); ++i) {
    const auto& e = w.episodes[i];
    const auto& rec = r.episodes[i].record;
    const auto& m = r.episodes[i].metrics;
    const auto& gt = w.groundTruth.at(e.episode_id);
    SCOPED_TRACE("episode " + std::to_string(e.episode_id));
    EXPECT_TRUE(r.scored[i]);
    EXPECT_EQ(rec.episode_id, std::to_string(e.episode_id));
    // the same positions as the follower's own run, action by action
    EXPECT_EQ(rec.positions, w.followerPositions[i]);
    EXPECT_EQ(rec.positions.size(), rec.headings.size());
    ASSERT_EQ(rec.actions.size(), gt.actions.size());
    for (size_t k = 0; k < gt.actions.size(); ++k)
      EXPECT_EQ(rec.actions[k], static_cast<int>(gt.actions[k]));
    EXPECT_TRUE(rec.called_stop);
    EXPECT_EQ(rec.steps_taken, static_cast<int>(gt.actions.size()));
    EXPECT_EQ(rec.reference_path, gt.locations);  // ground truth given
    EXPECT_EQ(rec.goal, e.goals.front().position);

    // hand-computed: TL sums the follower's steps, d0 the navmesh geodesic
    double tl = 0.0;
    for (size_t k = 1; k < rec.positions.size(); ++k)
      tl += (rec.positions[k] - rec.positions[k - 1]).norm();
    const double d0 =
        w.scene->navmesh().geodesicDistance(rec.positions.front(), rec.goal);
    EXPECT_NEAR(rec.start_distance, d0, 1e-6);
    EXPECT_NEAR(m.path_length, tl, 1e-5);
    EXPECT_EQ(m.success, 1.0);
    EXPECT_EQ(m.oracle_success, 1.0);
    EXPECT_NEAR(m.spl, d0 / std::max(d0, tl), 1e-6);
    EXPECT_GT(m.spl, 0.5);  // the follower walks close to the shortest path
    EXPECT_LT(m.distance_to_goal, 0.5 + 0.25);  // within its goal radius
    EXPECT_EQ(m.steps_taken, static_cast<double>(gt.actions.size()));
  }
  EXPECT_EQ(r.stats.num_episodes, static_cast<int>(w.episodes.size()));
  EXPECT_EQ(r.stats.mean.success, 1.0);

  // progress after every episode; every episode started exactly once, the
  // first three in environments 0, 1, 2 and then each environment refilled
  // as soon as its episode ended
  ASSERT_EQ(progress.size(), w.episodes.size());
  for (size_t k = 0; k < progress.size(); ++k)
    EXPECT_EQ(progress[k], std::make_pair(static_cast<int>(k) + 1, 10));
  ASSERT_EQ(agent.resets.size(), w.episodes.size());
  for (size_t k = 0; k < agent.resets.size(); ++k)
    EXPECT_EQ(agent.resets[k].second, w.episodes[k].episode_id);
  EXPECT_EQ(agent.resets[0].first, 0);
  EXPECT_EQ(agent.resets[1].first, 1);
  EXPECT_EQ(agent.resets[2].first, 2);
  // the environment of the shortest of the first three episodes runs the 4th
  int shortest = 0;
  for (int k = 1; k < 3; ++k)
    if (w.groundTruth.at(w.episodes[static_cast<size_t>(k)].episode_id)
            .actions.size() <
        w.groundTruth.at(w.episodes[static_cast<size_t>(shortest)].episode_id)
            .actions.size())
      shortest = k;
  EXPECT_EQ(agent.resets[3].first, shortest);
}

TEST(EvaluatorTest, AnAgentThatNeverStopsHitsTheStepLimitAndFails) {
  const auto& w = rolloutTestWorld();
  SpinningAgent agent;
  const std::vector<data::Episode> episodes(w.episodes.begin(),
                                            w.episodes.begin() + 4);
  const EvaluationResult r = run(agent, episodes, nullptr, 2, 1);
  for (size_t i = 0; i < episodes.size(); ++i) {
    const auto& rec = r.episodes[i].record;
    const auto& m = r.episodes[i].metrics;
    EXPECT_FALSE(rec.called_stop);
    EXPECT_EQ(rec.steps_taken, w.task.max_episode_steps);
    EXPECT_EQ(rec.positions.size(),
              static_cast<size_t>(w.task.max_episode_steps) + 1);
    EXPECT_EQ(m.success, 0.0);
    EXPECT_EQ(m.spl, 0.0);
    EXPECT_EQ(m.path_length, 0.0);  // turning in place
    // never moved: the final distance is the start distance (> 3 m, so no
    // oracle success either); reference from the episode without a gt
    EXPECT_NEAR(m.distance_to_goal, rec.start_distance, 1e-6);
    EXPECT_GT(rec.start_distance, 3.0);
    EXPECT_EQ(m.oracle_success, 0.0);
    EXPECT_EQ(rec.reference_path, episodes[i].reference_path);
    // 24 left turns of 15 degrees bring the heading back to the start
    EXPECT_NEAR(wrapAngle(rec.headings[24] - rec.headings[0]), 0.0f, 1e-4f);
  }
  EXPECT_EQ(r.stats.mean.success, 0.0);
  EXPECT_EQ(r.stats.mean.steps_taken, w.task.max_episode_steps);
}

TEST(EvaluatorTest, ResultsDoNotDependOnThreadsOrEnvironmentCount) {
  const auto& w = rolloutTestWorld();
  RandomWalkAgent a1(1, /*seed=*/9);
  RandomWalkAgent a2(4, /*seed=*/9);
  RandomWalkAgent a3(3, /*seed=*/9);
  const EvaluationResult serial = run(a1, w.episodes, &w.groundTruth, 1, 1);
  const EvaluationResult parallel = run(a2, w.episodes, &w.groundTruth, 4, 2);
  const EvaluationResult other = run(a3, w.episodes, &w.groundTruth, 3, 3);
  int moved = 0;
  for (size_t i = 0; i < w.episodes.size(); ++i) {
    for (const EvaluationResult* r : {&parallel, &other}) {
      EXPECT_EQ(r->episodes[i].record.positions,
                serial.episodes[i].record.positions);
      EXPECT_EQ(r->episodes[i].record.actions,
                serial.episodes[i].record.actions);
      EXPECT_EQ(r->episodes[i].metrics, serial.episodes[i].metrics);
    }
    if (serial.episodes[i].metrics.path_length > 0.0) ++moved;
  }
  EXPECT_EQ(parallel.stats, serial.stats);
  EXPECT_EQ(other.stats, serial.stats);
  EXPECT_GT(moved, 5);  // the random agent actually walks
}

TEST(EvaluatorTest, EpisodesWithoutGoalsAreRecordedButNotScored) {
  const auto& w = rolloutTestWorld();
  std::vector<data::Episode> episodes(w.episodes.begin(),
                                      w.episodes.begin() + 3);
  episodes[0].goals.clear();
  episodes[2].goals.clear();
  ReplayAgent agent(w.groundTruth);
  const EvaluationResult r = run(agent, episodes, nullptr, 2, 2);
  EXPECT_EQ(r.scored, (std::vector<uint8_t>{0, 1, 0}));
  EXPECT_EQ(r.stats.num_episodes, 1);
  EXPECT_EQ(r.stats.mean, r.episodes[1].metrics);
  EXPECT_EQ(r.episodes[0].record.positions, w.followerPositions[0]);
  EXPECT_TRUE(r.episodes[0].record.reference_path.empty());
  EXPECT_EQ(r.episodes[0].metrics, EpisodeMetrics{});
  // leaderboard steps of an unscored record: one per position
  EXPECT_EQ(leaderboardSteps(r.episodes[2].record).size(),
            w.followerPositions[2].size());

  // a whole split without goals: nothing to average
  for (auto& e : episodes) e.goals.clear();
  ReplayAgent again(w.groundTruth);
  const EvaluationResult none = run(again, episodes, nullptr, 2, 1);
  EXPECT_EQ(none.stats.num_episodes, 0);
  EXPECT_EQ(none.episodes.size(), 3u);
}

TEST(EvaluatorTest, AnEpisodeMissingFromTheGroundTruthIsNamed) {
  const auto& w = rolloutTestWorld();
  data::GroundTruth partial = w.groundTruth;
  partial.erase(w.episodes[2].episode_id);
  ReplayAgent agent(w.groundTruth);
  EXPECT_THAT(
      [&] { run(agent, w.episodes, &partial, 2, 1); },
      ::testing::Throws<std::invalid_argument>(::testing::Property(
          &std::exception::what,
          HasSubstr("episode " + std::to_string(w.episodes[2].episode_id) +
                    " (scene procedural/h5/h5.glb) has no entry in the ground "
                    "truth"))));
  EXPECT_TRUE(agent.resets.empty());  // checked before anything ran
}

TEST(EvaluatorTest, AnAgentReturningTheWrongNumberOfActionsIsAnError) {
  class Broken : public Agent {
   public:
    void reset(int, const data::Episode&) override {}
    std::vector<sim::Action> act(VectorEnv&, std::span<const int>) override {
      return {sim::Action::kStop};
    }
    bool needsObservations() const override { return false; }
  } agent;
  const auto& w = rolloutTestWorld();
  EXPECT_THAT([&] { run(agent, w.episodes, nullptr, 3, 1); },
              ::testing::Throws<std::invalid_argument>(::testing::Property(
                  &std::exception::what,
                  HasSubstr("returned 1 actions for 3 environments"))));
}

TEST(EvaluatorTest, FastDtwIsSelectedByTheConfig) {
  EvalConfig c;
  EXPECT_EQ(metricsOptions(c, 3.0).dtw, DtwMethod::kExact);
  c.dtw = "fast";
  EXPECT_EQ(metricsOptions(c, 2.5).dtw, DtwMethod::kFast);
  EXPECT_EQ(metricsOptions(c, 2.5).success_distance, 2.5);
  c.dtw = "slow";
  EXPECT_THROW(metricsOptions(c, 3.0), std::invalid_argument);
}

TEST(EvaluatorTest, NoEpisodesGiveAnEmptyResult) {
  SpinningAgent agent;
  const EvaluationResult r = run(agent, {}, nullptr, 2, 1);
  EXPECT_TRUE(r.episodes.empty());
  EXPECT_EQ(r.stats.num_episodes, 0);
}

// ---------------------------------------------------------------------------
// RxR's action space
// ---------------------------------------------------------------------------

// Looks up once in every episode, then hands over to the oracle.
class LookUpThenOracle : public Agent {
 public:
  LookUpThenOracle(const sim::AgentConfig& agent, int numEnvs)
      : oracle_(agent, /*goalRadius=*/0.5f, OracleMode::kGoal, numEnvs),
        looked_(static_cast<size_t>(numEnvs), false) {}
  void reset(int env, const data::Episode& episode) override {
    oracle_.reset(env, episode);
    looked_[static_cast<size_t>(env)] = false;
  }
  std::vector<sim::Action> act(VectorEnv& envs,
                               std::span<const int> active) override {
    std::vector<sim::Action> actions = oracle_.act(envs, active);
    for (size_t k = 0; k < active.size(); ++k) {
      const auto env = static_cast<size_t>(active[k]);
      if (!looked_[env]) actions[k] = sim::Action::kLookUp;
      looked_[env] = true;
    }
    return actions;
  }
  bool needsObservations() const override { return false; }

 private:
  OracleAgent oracle_;
  std::vector<bool> looked_;
};

TEST(EvaluatorTest, RxrRecordsThePitchAndTheOracleLevelsTheCamera) {
  const auto& w = rolloutTestWorld();
  sim::SimConfig rxr = w.sim;
  rxr.agent.look_actions = true;
  auto cache = std::make_shared<SceneCache>(rxr);
  VectorEnv envs(/*numEnvs=*/2, rxr, w.task, cache, /*threads=*/2);
  LookUpThenOracle agent(rxr.agent, /*numEnvs=*/2);
  const EvaluationResult looked = evaluateEpisodes(
      agent, envs, w.episodes, &w.groundTruth, evalConfig(2, 2), {});
  // the plain oracle in the R2R action space, for comparison
  OracleAgent oracle(w.sim.agent, 0.5f, OracleMode::kGoal, 2);
  const EvaluationResult plain =
      run(oracle, w.episodes, &w.groundTruth, /*numEnvs=*/2, /*threads=*/2);
  const float tilt = degToRad(rxr.agent.tilt_angle);
  for (size_t i = 0; i < w.episodes.size(); ++i) {
    SCOPED_TRACE("episode " + std::to_string(w.episodes[i].episode_id));
    const EpisodeRecord& rec = looked.episodes[i].record;
    const EpisodeRecord& r2r = plain.episodes[i].record;
    EXPECT_TRUE(r2r.pitches.empty());
    // LOOK_UP, the oracle's LOOK_DOWN back to level, then the R2R route
    ASSERT_EQ(rec.actions.size(), r2r.actions.size() + 2);
    EXPECT_EQ(rec.actions[0], 4);
    EXPECT_EQ(rec.actions[1], 5);
    EXPECT_EQ(std::vector<int>(rec.actions.begin() + 2, rec.actions.end()),
              r2r.actions);
    ASSERT_EQ(rec.pitches.size(), rec.positions.size());
    EXPECT_EQ(rec.pitches[0], 0.0f);
    EXPECT_NEAR(rec.pitches[1], tilt, 1e-6f);
    for (size_t k = 2; k < rec.pitches.size(); ++k)
      EXPECT_NEAR(rec.pitches[k], 0.0f, 1e-6f);
    // the looks moved nothing: same path, same metrics but the step count
    EXPECT_EQ(
        std::vector<Vec3f>(rec.positions.begin() + 2, rec.positions.end()),
        r2r.positions);
    EXPECT_EQ(looked.episodes[i].metrics.spl, plain.episodes[i].metrics.spl);
    EXPECT_EQ(looked.episodes[i].metrics.steps_taken,
              plain.episodes[i].metrics.steps_taken + 2);
  }
}

}  // namespace
}  // namespace vln::rollout
