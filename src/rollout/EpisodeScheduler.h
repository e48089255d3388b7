#pragma once
// The one episode loop behind every rollout of the project: evaluation
// (Evaluator.h), teacher-forcing and DAgger collection (train/Collector.h)
// and the point-goal pretraining rollouts (train/PointNavPretrainer.h).
//
//   pending episodes -> idle environments -> act -> step -> record ->
//   finish -> refill the environments that finished
//
// The order is a function of the number of environments only: episodes
// start in increasing index order, each in the lowest idle environment;
// every round the running environments act and step together in increasing
// environment order; the ones whose episodes ended (STOP or the step limit)
// finish together, in environment order, and take the next pending
// episodes. Which environment runs an episode, and which episodes share a
// batch, therefore never depend on thread timing.
//
// A job says where each episode starts and fills the hooks; the scheduler
// owns the bookkeeping. All hooks run on the calling thread; a hook may use
// VectorEnv::forEach() to work on its environments in parallel.

#include <cstdint>
#include <span>
#include <vector>

#include "rollout/VectorEnv.h"
#include "sim/Agent.h"

namespace vln::rollout {

/// Environments and the episodes they run, in increasing environment order:
/// environment envs[k] runs episode episodes[k] (an index into the job's
/// list).
struct EnvBatch {
  std::vector<int> envs;
  std::vector<int> episodes;
  size_t size() const { return envs.size(); }
  bool empty() const { return envs.empty(); }
  /// The position of environment `env` in the batch (envs[k] == env);
  /// `env` must be in it. For hooks that work per environment in parallel
  /// (VectorEnv::forEach()).
  size_t indexOf(int env) const;
};

/// What a rollout does at each point of the loop.
class EpisodeJob {
 public:
  virtual ~EpisodeJob() = default;
  /// Where episode `index` starts. Called just before its environment is
  /// reset, in index order; a job may check the episode here and throw.
  virtual EpisodeStart startOf(int index) = 0;
  /// The environments of `started` have been reset to their episodes (and
  /// rendered when the run renders).
  virtual void started(const EnvBatch& started) { (void)started; }
  /// One action per environment of `running`, in its order, from the
  /// environments' current states (and observations).
  virtual std::vector<sim::Action> act(const EnvBatch& running) = 0;
  /// The environments of `running` took `actions` with `results` (same
  /// order); rendered when the run renders.
  virtual void stepped(const EnvBatch& running,
                       std::span<const sim::Action> actions,
                       std::span<const sim::StepResult> results) {
    (void)running;
    (void)actions;
    (void)results;
  }
  /// The episodes of `ended` are over (STOP or task.max_episode_steps);
  /// their environments still hold the final state and are refilled right
  /// after this call.
  virtual void finished(const EnvBatch& ended) = 0;
};

/// What runEpisodes() did.
struct RolloutCounts {
  int64_t episodes = 0;  ///< episodes run to their end
  int64_t steps = 0;     ///< actions taken over all episodes
};

/// Runs episodes 0 .. count-1 of `job` on `envs` to their ends (see the file
/// comment for the order). With `render`, observations are rendered after
/// every reset and step; without, a hook renders what it needs
/// (VectorEnv::render()). Throws std::invalid_argument when `act` returns
/// another number of actions than environments.
RolloutCounts runEpisodes(VectorEnv& envs, int count, EpisodeJob& job,
                          bool render);

}  // namespace vln::rollout
