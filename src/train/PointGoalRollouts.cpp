#include "train/PointGoalRollouts.h"

#include "common/Check.h"
#include "common/Progress.h"
#include "common/Random.h"
#include "rollout/EpisodeScheduler.h"
#include "sim/Follower.h"

namespace vln::train {
namespace {

// draws of a start/goal pair before a house is declared unable to host an
// episode of the requested range
constexpr int kMaxEpisodeDraws = 1000;

}  // namespace

// ===========================================================================
// sensor and episodes
// ===========================================================================

std::array<float, 3> pointGoalObservation(const sim::AgentState& agent,
                                          const Vec3f& goal) {
  const Vec3f delta = goal - agent.position;
  const float rho = std::hypot(delta.x(), delta.z());
  // heading of the goal direction minus the agent's heading, so positive
  // means "turn left" as for headings (common/Math.h)
  const float phi = wrapAngle(forwardToHeading(delta) - agent.heading);
  return {rho, std::cos(phi), std::sin(phi)};
}

std::vector<PointGoalEpisode> samplePointGoalEpisodes(
    const std::vector<std::shared_ptr<const sim::Scene>>& scenes, int count,
    float minDistance, float maxDistance, uint64_t seed) {
  VLN_CHECK_ARG(!scenes.empty(), "samplePointGoalEpisodes(): no scenes");
  VLN_CHECK_ARG(minDistance < maxDistance,
                "samplePointGoalEpisodes(): the distance range [", minDistance,
                ", ", maxDistance, "] is empty");
  std::vector<PointGoalEpisode> episodes;
  episodes.reserve(static_cast<size_t>(std::max(count, 0)));
  for (int k = 0; k < count; ++k) {
    // one generator per episode: episode k does not depend on `count`
    std::mt19937_64 rng(common::deriveSeed(seed, static_cast<uint64_t>(k)));
    PointGoalEpisode episode;
    episode.house = common::uniformIndex(rng, static_cast<int>(scenes.size()));
    const sim::Scene& scene = *scenes[static_cast<size_t>(episode.house)];
    const sim::NavMesh& navmesh = scene.navmesh();
    bool found = false;
    for (int draw = 0; draw < kMaxEpisodeDraws && !found; ++draw) {
      const Vec3f start = navmesh.randomPoint(rng, /*island=*/0);
      const Vec3f goal = navmesh.randomPoint(rng, /*island=*/0);
      const float distance = navmesh.geodesicDistance(start, goal);
      if (std::isfinite(distance) && distance >= minDistance &&
          distance <= maxDistance) {
        episode.start.position = start;
        episode.goal = goal;
        episode.geodesic_distance = distance;
        found = true;
      }
    }
    VLN_CHECK_ARG(found, "samplePointGoalEpisodes(): scene '", scene.name(),
                  "' has no start/goal pair at a geodesic distance in [",
                  minDistance, ", ", maxDistance, "] m after ",
                  kMaxEpisodeDraws,
                  " draws (pretrain.min_goal_distance / max_goal_distance "
                  "do not fit the house)");
    episode.start.heading = common::uniformRange(rng, -kPi, kPi);
    episodes.push_back(episode);
  }
  return episodes;
}

namespace {

// What the point-goal rollout keeps per environment between steps.
struct PointGoalEnv {
  std::mt19937_64 rng;
  int prev = 0;
  bool first = true;
  double path = 0.0;
  std::array<float, 3> goal{};
  sim::Action oracle = sim::Action::kStop;
};

// One step of `policy` for the environments `active` (their `states` and
// depth `observations`, rows `active` of `hidden` [environments, H], which
// advance): the argmax actions.
std::vector<int64_t> policyArgmax(
    models::PointNavPolicyImpl& policy, const std::vector<int>& active,
    const std::vector<const PointGoalEnv*>& states,
    const std::vector<const sim::Observation*>& observations,
    torch::Tensor& hidden, const ExperimentConfig& config,
    torch::Device device) {
  torch::NoGradGuard noGrad;
  const int64_t n = static_cast<int64_t>(active.size());
  const int64_t width = config.sim.depth.camera.width;
  const int64_t height = config.sim.depth.camera.height;
  const auto pixels = static_cast<size_t>(width * height);
  std::vector<float> goal(static_cast<size_t>(n) * models::kPointGoalDims);
  std::vector<int64_t> prev(static_cast<size_t>(n)),
      rows(active.begin(), active.end());
  std::vector<float> notDone(static_cast<size_t>(n));
  torch::Tensor depth;
  if (policy.usesDepth()) depth = torch::empty({n, height, width, 1});
  for (int64_t i = 0; i < n; ++i) {
    const PointGoalEnv& env = *states[static_cast<size_t>(i)];
    std::copy(env.goal.begin(), env.goal.end(),
              goal.begin() + i * models::kPointGoalDims);
    prev[static_cast<size_t>(i)] = env.prev;
    notDone[static_cast<size_t>(i)] = env.first ? 0.0f : 1.0f;
    if (depth.defined()) {
      const std::vector<float>& frame =
          observations[static_cast<size_t>(i)]->depth;
      std::copy(frame.begin(),
                frame.begin() + static_cast<std::ptrdiff_t>(pixels),
                depth.data_ptr<float>() + i * static_cast<int64_t>(pixels));
    }
  }
  models::PointNavInputs inputs;
  if (depth.defined()) {
    inputs.depth = depth.to(device);
    inputs.frame_index =
        torch::arange(n, torch::TensorOptions(torch::kLong).device(device));
  }
  inputs.goal =
      torch::from_blob(goal.data(), {1, n, models::kPointGoalDims}).to(device);
  inputs.prev_actions =
      torch::from_blob(prev.data(), {1, n}, torch::kLong).to(device);
  inputs.not_done = torch::from_blob(notDone.data(), {1, n}).to(device);
  const torch::Tensor rowIndex =
      torch::from_blob(rows.data(), {n}, torch::kLong).to(device);
  auto [logits, next] =
      policy.forward(inputs, hidden.index_select(0, rowIndex));
  hidden.index_copy_(0, rowIndex, next);
  const torch::Tensor best = logits[0].argmax(-1).to(torch::kCPU).contiguous();
  return std::vector<int64_t>(best.data_ptr<int64_t>(),
                              best.data_ptr<int64_t>() + n);
}

// The action `spec`'s driver takes in `env`; `policyAction` is the
// policy's argmax (-1 when the policy does not run).
sim::Action driverAction(const RolloutSpec& spec, PointGoalEnv& env,
                         int64_t policyAction, float successDistance) {
  switch (spec.driver) {
    case Driver::kMixed: {
      const bool takeOracle = common::uniform01(env.rng) < spec.beta;
      return takeOracle || policyAction < 0
                 ? env.oracle
                 : sim::actionFromInt(static_cast<int>(policyAction));
    }
    case Driver::kPolicy:
      return sim::actionFromInt(static_cast<int>(policyAction));
    case Driver::kRandom:
      // habitat's RandomAgent: STOP once the goal sensor reads arrival
      return env.goal[0] <= successDistance
                 ? sim::Action::kStop
                 : sim::actionFromInt(1 + common::uniformIndex(env.rng, 3));
    case Driver::kOracle:
      break;
  }
  return env.oracle;
}

// How episode `ep` ended in `state` after walking `path` metres.
Outcome outcomeOf(const PointGoalEpisode& ep, const sim::EpisodeState& state,
                  double path, const sim::NavMesh& navmesh,
                  float successDistance) {
  Outcome o;
  o.distance = navmesh.geodesicDistance(state.agent.position, ep.goal);
  o.success = state.called_stop && o.distance <= successDistance;
  o.path = path;
  o.steps = state.steps;
  const double d0 = ep.geodesic_distance;
  o.spl = o.success ? d0 / std::max(d0, o.path) : 0.0;
  return o;
}

class PointGoalJob : public rollout::EpisodeJob {
 public:
  PointGoalJob(const ExperimentConfig& config,
               const std::vector<std::shared_ptr<const sim::Scene>>& scenes,
               const std::vector<PointGoalEpisode>& episodes,
               const RolloutSpec& spec, rollout::VectorEnv& envs,
               torch::Device device, const std::string& label)
      : config_(config),
        scenes_(scenes),
        episodes_(episodes),
        spec_(spec),
        envs_(envs),
        device_(device),
        // with beta = 1 the policy's actions are never taken: not run
        usePolicy_(spec.driver == Driver::kPolicy ||
                   (spec.driver == Driver::kMixed && spec.beta < 1.0)),
        needOracle_(spec.record != nullptr || spec.driver == Driver::kMixed ||
                    spec.driver == Driver::kOracle),
        depthScale_(config.sim.depth.normalize_depth
                        ? 1.0f
                        : config.sim.depth.max_depth),
        state_(static_cast<size_t>(envs.size())),
        outcomes_(episodes.size()),
        recordedBytes_(spec.bytesBefore),
        line_(label, static_cast<int64_t>(episodes.size()), "episodes") {
    VLN_ASSERT(!usePolicy_ || spec.policy != nullptr);
    for (const auto& scene : scenes_)
      followers_.emplace_back(scene->navmesh(), config_.sim.agent,
                              config_.pretrain.success_distance);
    if (usePolicy_) {
      spec.policy->eval();
      hidden_ = spec.policy->initialHidden(envs.size());
    }
    if (spec.record) spec.record->assign(episodes.size(), RecordedEpisode{});
  }

  // observations are needed to record frames or feed the depth policy
  bool renders() const {
    return spec_.record != nullptr || (usePolicy_ && spec_.policy->usesDepth());
  }
  std::vector<Outcome> outcomes() { return std::move(outcomes_); }

  rollout::EpisodeStart startOf(int index) override {
    const PointGoalEpisode& ep = episodes_[static_cast<size_t>(index)];
    rollout::EpisodeStart start;
    start.scene = scenes_[static_cast<size_t>(ep.house)];
    start.agent = ep.start;
    return start;
  }

  void started(const rollout::EnvBatch& batch) override {
    for (size_t k = 0; k < batch.size(); ++k) {
      // episode k's coins and random actions are its own: the result does
      // not depend on which environment runs it
      PointGoalEnv& env = state_[static_cast<size_t>(batch.envs[k])];
      env = PointGoalEnv{};
      env.rng.seed(common::deriveSeed(
          spec_.seed, static_cast<uint64_t>(batch.episodes[k])));
    }
  }

  std::vector<sim::Action> act(const rollout::EnvBatch& running) override {
    // sensors and the follower's action, in parallel
    envs_.forEach(running.envs, [&](int e) {
      PointGoalEnv& env = state_[static_cast<size_t>(e)];
      const PointGoalEpisode& ep =
          episodes_[static_cast<size_t>(running.episodes[running.indexOf(e)])];
      const sim::AgentState& agent = envs_.state(e).agent;
      env.goal = pointGoalObservation(agent, ep.goal);
      if (needOracle_)
        env.oracle = followers_[static_cast<size_t>(ep.house)].nextAction(
            agent, ep.goal);
    });
    std::vector<int64_t> policyActions;
    if (usePolicy_) {
      std::vector<const PointGoalEnv*> states;
      std::vector<const sim::Observation*> observations;
      for (int e : running.envs) {
        states.push_back(&state_[static_cast<size_t>(e)]);
        observations.push_back(&envs_.observation(e));
      }
      policyActions = policyArgmax(*spec_.policy, running.envs, states,
                                   observations, hidden_, config_, device_);
    }

    // pick and record the actions
    std::vector<sim::Action> actions(running.size(), sim::Action::kStop);
    for (size_t i = 0; i < running.size(); ++i) {
      PointGoalEnv& env = state_[static_cast<size_t>(running.envs[i])];
      actions[i] = driverAction(spec_, env, usePolicy_ ? policyActions[i] : -1,
                                config_.pretrain.success_distance);
      if (spec_.record != nullptr) {
        RecordedEpisode& rec =
            (*spec_.record)[static_cast<size_t>(running.episodes[i])];
        const size_t before = rec.bytes();
        rec.append(envs_.observation(running.envs[i]).depth, depthScale_,
                   env.goal, env.prev, env.oracle);
        recordedBytes_ += rec.bytes() - before;
      }
    }
    if (spec_.record != nullptr) checkBudget();
    return actions;
  }

  void stepped(const rollout::EnvBatch& running,
               std::span<const sim::Action> actions,
               std::span<const sim::StepResult> results) override {
    for (size_t i = 0; i < running.size(); ++i) {
      PointGoalEnv& env = state_[static_cast<size_t>(running.envs[i])];
      env.path += results[i].distance;
      env.prev = static_cast<int>(actions[i]);
      env.first = false;
    }
  }

  void finished(const rollout::EnvBatch& ended) override {
    for (size_t k = 0; k < ended.size(); ++k) {
      const auto index = static_cast<size_t>(ended.episodes[k]);
      const PointGoalEpisode& ep = episodes_[index];
      outcomes_[index] =
          outcomeOf(ep, envs_.state(ended.envs[k]),
                    state_[static_cast<size_t>(ended.envs[k])].path,
                    scenes_[static_cast<size_t>(ep.house)]->navmesh(),
                    config_.pretrain.success_distance);
      line_.advance();
    }
  }

 private:
  void checkBudget() const {
    VLN_CHECK_IO(recordedBytes_ <= spec_.byteBudget,
                 "depth_pointnav: the aggregated DAgger "
                 "frames need more than pretrain.max_memory_gib = ",
                 config_.pretrain.max_memory_gib,
                 " GiB; lower pretrain.samples, pretrain.iterations or "
                 "task.max_episode_steps, or raise pretrain.max_memory_gib");
  }

  const ExperimentConfig& config_;
  const std::vector<std::shared_ptr<const sim::Scene>>& scenes_;
  const std::vector<PointGoalEpisode>& episodes_;
  const RolloutSpec& spec_;
  rollout::VectorEnv& envs_;
  torch::Device device_;
  bool usePolicy_, needOracle_;
  float depthScale_;
  std::vector<sim::ShortestPathFollower> followers_;  // per house
  std::vector<PointGoalEnv> state_;                   // per environment
  torch::Tensor hidden_;                              // [environments, H]
  std::vector<Outcome> outcomes_;
  size_t recordedBytes_;
  common::ProgressLine line_;
};

}  // namespace

std::vector<Outcome> runPointGoalEpisodes(
    const ExperimentConfig& config,
    const std::vector<std::shared_ptr<const sim::Scene>>& scenes,
    const std::vector<PointGoalEpisode>& episodes, const RolloutSpec& spec,
    torch::Device device, const std::string& label) {
  const int numEnvs = std::max(
      1, std::min(static_cast<int>(episodes.size()), config.trainer.num_envs));
  rollout::VectorEnv envs(numEnvs, config.sim, config.task, nullptr,
                          config.trainer.env_threads);
  PointGoalJob job(config, scenes, episodes, spec, envs, device, label);
  rollout::runEpisodes(envs, static_cast<int>(episodes.size()), job,
                       job.renders());
  return job.outcomes();
}

}  // namespace vln::train
