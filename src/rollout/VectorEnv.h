#pragma once
// Several environments stepped together, each with its own Simulator, on a
// thread pool: the batch of episodes behind evaluation and DAgger collection.
// Scenes are loaded once and shared read-only between environments.

#include <cstdint>
#include <list>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "common/ThreadPool.h"
#include "data/Episode.h"
#include "sim/Simulator.h"

namespace vln::rollout {

/// Loads scenes by episode scene id under sim.scenes_dir, once, and shares
/// them. Thread-safe; concurrent requests for one scene wait for one load.
class SceneCache {
 public:
  /// Keeps at most `capacity` scenes alive beyond those still in use.
  explicit SceneCache(sim::SimConfig config, size_t capacity = 32);
  /// The scene of `sceneId` (resolved with data::resolveScenePath()).
  /// Throws naming the scene id when it cannot be found or loaded.
  std::shared_ptr<const sim::Scene> get(const std::string& sceneId);
  /// Scenes loaded so far (for logs and tests).
  int loads() const;
  const sim::SimConfig& config() const { return config_; }

 private:
  struct Entry;
  sim::SimConfig config_;
  size_t capacity_;
  mutable std::mutex mutex_;
  std::map<std::string, std::shared_ptr<Entry>> entries_;
  std::list<std::string> recent_;  ///< most recent first
  int loads_ = 0;
};

/// Where an episode starts: a dataset episode (its scene through the scene
/// cache, its start pose), or a scene and a pose of the caller's (e.g. a
/// point-goal pretraining episode).
struct EpisodeStart {
  /// Must outlive its use by the environment; null for a scene and pose.
  const data::Episode* episode = nullptr;
  std::shared_ptr<const sim::Scene> scene;
  sim::AgentState agent;

  static EpisodeStart of(const data::Episode& episode) {
    EpisodeStart start;
    start.episode = &episode;
    return start;
  }
};

/// A batch of environments. Environment i runs one episode at a time; the
/// caller decides which environments to reset and step.
class VectorEnv {
 public:
  /// `scenes` may be null when every episode names its scene
  /// (EpisodeStart::scene).
  VectorEnv(int numEnvs, const sim::SimConfig& sim, const sim::TaskConfig& task,
            std::shared_ptr<SceneCache> scenes, int threads);
  ~VectorEnv();

  int size() const { return static_cast<int>(envs_.size()); }

  /// Starts starts[k] in environment envs[k] and, when `render`, renders
  /// its first observation; in parallel (scenes load in parallel too).
  /// Throws std::invalid_argument naming a dataset episode whose start is
  /// not on the navmesh.
  void reset(std::span<const int> envs, std::span<const EpisodeStart> starts,
             bool render = true);
  /// reset() of the dataset episodes `episodes`.
  void reset(std::span<const int> envs,
             std::span<const data::Episode* const> episodes,
             bool render = true);
  /// Applies actions[k] in environment envs[k] and, when `render`, renders
  /// the new observation; in parallel. Returns the step results in order.
  /// sim::Action::kTeleport takes the environment's requested teleport
  /// (requestTeleport()) as its one step. Throws std::invalid_argument for
  /// kTeleport without a request, or another action with one pending.
  std::vector<sim::StepResult> step(std::span<const int> envs,
                                    std::span<const sim::Action> actions,
                                    bool render = true);
  /// Asks environment `env` to place its agent at `target` (world frame) at
  /// its next step(), which must then be sim::Action::kTeleport: how an
  /// Agent's act() requests a move outside the low-level action space (a
  /// waypoint agent with waypoint_agent.execution teleport). The step is
  /// sim::Simulator::teleport(): snapped to the navmesh on the agent's
  /// island or refused, counted in the episode's steps and capped by
  /// task.max_episode_steps, and its end recorded like any step's. A reset()
  /// drops a pending request.
  void requestTeleport(int env, const sim::AgentState& target);
  /// Renders the current observation of the listed environments.
  void render(std::span<const int> envs);

  /// Last rendered observation of environment `env`.
  const sim::Observation& observation(int env) const;
  /// Episode state (agent pose, steps, done) of environment `env`.
  const sim::EpisodeState& state(int env) const;
  /// The dataset episode environment `env` is running (an error when it
  /// was started from a scene and a pose).
  const data::Episode& episode(int env) const;
  /// The simulator of environment `env` (its scene, navmesh, renderer).
  sim::Simulator& simulator(int env);

  /// Runs fn(env) for every listed environment on the pool.
  void forEach(std::span<const int> envs, const std::function<void(int)>& fn);

 private:
  struct Env;
  std::vector<std::unique_ptr<Env>> envs_;
  sim::SimConfig sim_;
  sim::TaskConfig task_;
  std::shared_ptr<SceneCache> scenes_;
  common::ThreadPool pool_;
};

}  // namespace vln::rollout
