#include "rollout/VectorEnv.h"

#include "common/Check.h"

namespace vln::rollout {

// ---------------------------------------------------------------------------
// SceneCache

struct SceneCache::Entry {
  std::mutex mutex;
  std::shared_ptr<const sim::Scene> scene;
  std::weak_ptr<const sim::Scene> evicted;  ///< revived while still in use
};

SceneCache::SceneCache(sim::SimConfig config, size_t capacity)
    : config_(std::move(config)), capacity_(std::max<size_t>(capacity, 1)) {}

std::shared_ptr<const sim::Scene> SceneCache::get(const std::string& sceneId) {
  std::shared_ptr<Entry> entry;
  {
    std::lock_guard lock(mutex_);
    auto& slot = entries_[sceneId];
    if (!slot) slot = std::make_shared<Entry>();
    entry = slot;
    recent_.remove(sceneId);
    recent_.push_front(sceneId);
  }
  std::shared_ptr<const sim::Scene> scene;
  {
    // one loader per scene; others wait on the entry's mutex
    std::lock_guard entryLock(entry->mutex);
    if (!entry->scene) entry->scene = entry->evicted.lock();
    if (!entry->scene) {
      auto file = data::resolveScenePath(config_.scenes_dir, sceneId);
      entry->scene = sim::Scene::load(file, config_);
      std::lock_guard lock(mutex_);
      ++loads_;
    }
    scene = entry->scene;
  }
  // drop strong references to the least recently used scenes; environments
  // still holding one keep it alive and it is revived from the weak pointer
  std::lock_guard lock(mutex_);
  while (recent_.size() > capacity_) {
    auto victim = entries_.find(recent_.back());
    recent_.pop_back();
    if (victim != entries_.end() && victim->second != entry) {
      std::unique_lock victimLock(victim->second->mutex, std::try_to_lock);
      if (victimLock.owns_lock()) {
        victim->second->evicted = victim->second->scene;
        victim->second->scene.reset();
      }
    }
  }
  return scene;
}

int SceneCache::loads() const {
  std::lock_guard lock(mutex_);
  return loads_;
}

// ---------------------------------------------------------------------------
// VectorEnv

struct VectorEnv::Env {
  std::unique_ptr<sim::Simulator> simulator;
  bool started = false;                   ///< reset() at least once
  const data::Episode* episode = nullptr;  ///< null for a scene and a pose
  sim::Observation observation;
  /// requestTeleport()'s target, taken by the next step()
  std::optional<sim::AgentState> teleport;
};

VectorEnv::VectorEnv(int numEnvs, const sim::SimConfig& sim,
                     const sim::TaskConfig& task,
                     std::shared_ptr<SceneCache> scenes, int threads)
    : sim_(sim),
      task_(task),
      scenes_(std::move(scenes)),
      pool_(std::max(1, std::min(threads, numEnvs))) {
  VLN_CHECK_ARG(numEnvs >= 1, "VectorEnv: numEnvs must be >= 1, got ", numEnvs);
  for (int i = 0; i < numEnvs; ++i) envs_.push_back(std::make_unique<Env>());
}

VectorEnv::~VectorEnv() = default;

void VectorEnv::forEach(std::span<const int> envs,
                        const std::function<void(int)>& fn) {
  for (int env : envs)
    VLN_CHECK_ARG(env >= 0 && env < size(), "VectorEnv: environment ", env,
                  " out of range [0, ", size(), ")");
  pool_.parallelFor(envs.size(), [&](size_t k) { fn(envs[k]); });
}

void VectorEnv::reset(std::span<const int> envs,
                      std::span<const EpisodeStart> starts, bool render) {
  VLN_CHECK_ARG(envs.size() == starts.size(), "VectorEnv::reset(): ",
                envs.size(), " environments for ", starts.size(),
                " episodes");
  for (size_t k = 0; k < envs.size(); ++k) {
    VLN_CHECK_ARG(envs[k] >= 0 && envs[k] < size(),
                  "VectorEnv::reset(): environment ", envs[k],
                  " out of range [0, ", size(), ")");
    VLN_CHECK_ARG(starts[k].episode || starts[k].scene,
                  "VectorEnv::reset(): environment ", envs[k],
                  " was given neither an episode nor a scene");
    VLN_CHECK_ARG(!starts[k].episode || scenes_,
                  "VectorEnv::reset(): episode ",
                  starts[k].episode->episode_id,
                  " names its scene by id, but this VectorEnv has no scene "
                  "cache");
  }
  pool_.parallelFor(envs.size(), [&](size_t k) {
    const EpisodeStart& start = starts[k];
    Env& e = *envs_[static_cast<size_t>(envs[k])];
    const data::Episode* episode = start.episode;
    auto scene = episode ? scenes_->get(episode->scene_id) : start.scene;
    if (!e.simulator)
      e.simulator = std::make_unique<sim::Simulator>(scene, sim_, task_);
    else if (e.simulator->scenePtr() != scene)
      e.simulator->setScene(scene);
    if (episode == nullptr) {
      e.simulator->reset(start.agent);
    } else {
      try {
        e.simulator->reset(
            {episode->start_position, episode->startHeading()});
      } catch (const std::exception& error) {
        throw std::invalid_argument("episode " +
                                    std::to_string(episode->episode_id) +
                                    " (scene " + episode->scene_id +
                                    "): start_position: " + error.what());
      }
    }
    e.episode = episode;
    e.started = true;
    e.teleport.reset();
    if (render) e.simulator->observe(e.observation);
  });
}

void VectorEnv::reset(std::span<const int> envs,
                      std::span<const data::Episode* const> episodes,
                      bool render) {
  std::vector<EpisodeStart> starts;
  starts.reserve(episodes.size());
  for (const data::Episode* episode : episodes)
    starts.push_back(EpisodeStart::of(*episode));
  reset(envs, starts, render);
}

std::vector<sim::StepResult> VectorEnv::step(
    std::span<const int> envs, std::span<const sim::Action> actions,
    bool render) {
  VLN_CHECK_ARG(envs.size() == actions.size(),
                "VectorEnv::step(): ", envs.size(), " environments for ",
                actions.size(), " actions");
  std::vector<sim::StepResult> results(envs.size());
  pool_.parallelFor(envs.size(), [&](size_t k) {
    int env = envs[k];
    VLN_CHECK_ARG(env >= 0 && env < size(), "VectorEnv::step(): environment ",
                  env, " out of range");
    Env& e = *envs_[static_cast<size_t>(env)];
    VLN_CHECK_ARG(e.started, "VectorEnv::step(): environment ", env,
                  " was never reset");
    if (actions[k] == sim::Action::kTeleport) {
      VLN_CHECK_ARG(e.teleport, "VectorEnv::step(): environment ", env,
                    " was given TELEPORT without requestTeleport()");
      results[k] = e.simulator->teleport(*e.teleport);
      e.teleport.reset();
    } else {
      VLN_CHECK_ARG(!e.teleport, "VectorEnv::step(): environment ", env,
                    " requested a teleport but was given ",
                    sim::actionName(actions[k]));
      results[k] = e.simulator->step(actions[k]);
    }
    if (render) e.simulator->observe(e.observation);
  });
  return results;
}

void VectorEnv::requestTeleport(int env, const sim::AgentState& target) {
  VLN_CHECK_ARG(env >= 0 && env < size(),
                "VectorEnv::requestTeleport(): environment ", env,
                " out of range [0, ", size(), ")");
  Env& e = *envs_[static_cast<size_t>(env)];
  VLN_CHECK_ARG(e.started, "VectorEnv::requestTeleport(): environment ", env,
                " was never reset");
  e.teleport = target;
}

void VectorEnv::render(std::span<const int> envs) {
  forEach(envs, [&](int env) {
    Env& e = *envs_[static_cast<size_t>(env)];
    VLN_CHECK_ARG(e.simulator, "VectorEnv::render(): environment ", env,
                  " was never reset");
    e.simulator->observe(e.observation);
  });
}

const sim::Observation& VectorEnv::observation(int env) const {
  return envs_.at(static_cast<size_t>(env))->observation;
}

const sim::EpisodeState& VectorEnv::state(int env) const {
  const Env& e = *envs_.at(static_cast<size_t>(env));
  VLN_CHECK_ARG(e.simulator, "VectorEnv::state(): environment ", env,
                " was never reset");
  return e.simulator->episode();
}

const data::Episode& VectorEnv::episode(int env) const {
  const Env& e = *envs_.at(static_cast<size_t>(env));
  VLN_CHECK_ARG(e.episode, "VectorEnv::episode(): environment ", env,
                e.started ? " runs no dataset episode" : " was never reset");
  return *e.episode;
}

sim::Simulator& VectorEnv::simulator(int env) {
  Env& e = *envs_.at(static_cast<size_t>(env));
  VLN_CHECK_ARG(e.simulator, "VectorEnv::simulator(): environment ", env,
                " was never reset");
  return *e.simulator;
}

}  // namespace vln::rollout
