#include "train/PointNavPretrainer.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

#include "common/Check.h"
#include "common/Json.h"
#include "common/Progress.h"
#include "common/Random.h"
#include "common/ThreadPool.h"
#include "models/Loss.h"
#include "models/Policy.h"
#include "models/StateDict.h"
#include "sim/Follower.h"
#include "rollout/EpisodeScheduler.h"
#include "sim/Simulator.h"
#include "train/MetricsLog.h"
#include "train/PretrainCommon.h"
#include "train/PretrainTasks.h"

namespace vln::train {
namespace fs = std::filesystem;

namespace {

// uint16 depth code of the top of the sensor range
constexpr float kDepthCodeMax = 65535.0f;
// stream labels of data::deriveSeed, so that no two uses share draws
constexpr uint64_t kTrainEpisodeStream = 1000;
constexpr uint64_t kCoinStream = 2000;
constexpr uint64_t kEpochStream = 3000;
constexpr uint64_t kEvalEpisodeStream = 4000;
constexpr uint64_t kEvalCoinStream = 5000;
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

// ===========================================================================
// rollouts
// ===========================================================================

// One recorded training episode; depth quantised to uint16 codes of the
// sensor range, the rest as the policy reads it.
struct RecordedEpisode {
  std::vector<uint16_t> depth;  // [T, H * W]
  std::vector<float> goal;      // [T, 3]
  std::vector<int8_t> prev;     // [T], the action before step t (0 at t = 0)
  std::vector<int8_t> label;    // [T], the follower's action

  int64_t length() const { return static_cast<int64_t>(label.size()); }
  size_t bytes() const {
    return depth.size() * sizeof(uint16_t) + goal.size() * sizeof(float) +
           prev.size() + label.size();
  }

  // appends one step: the depth frame as uint16 codes of [0, depthScale]
  void append(std::span<const float> frame, float depthScale,
              const std::array<float, 3>& goalObservation, int prevAction,
              sim::Action followerAction) {
    const size_t offset = depth.size();
    depth.resize(offset + frame.size());
    for (size_t p = 0; p < frame.size(); ++p) {
      const float v = std::clamp(frame[p] / depthScale, 0.0f, 1.0f);
      depth[offset + p] = static_cast<uint16_t>(std::lround(v * kDepthCodeMax));
    }
    goal.insert(goal.end(), goalObservation.begin(), goalObservation.end());
    prev.push_back(static_cast<int8_t>(prevAction));
    label.push_back(static_cast<int8_t>(followerAction));
  }
};

// Who picks the actions of a rollout.
enum class Driver {
  kMixed,   // DAgger: the follower with probability beta, else the policy
  kPolicy,  // the policy's argmax
  kRandom,  // habitat's RandomAgent
  kOracle,  // the follower
};

struct Outcome {
  bool success = false;
  double spl = 0.0;
  double distance = 0.0;
  double path = 0.0;
  int steps = 0;
};

PointNavMetrics summarise(const std::vector<Outcome>& outcomes) {
  PointNavMetrics m;
  m.episodes = static_cast<int64_t>(outcomes.size());
  if (outcomes.empty()) return m;
  for (const Outcome& o : outcomes) {
    m.success += o.success ? 1.0 : 0.0;
    m.spl += o.spl;
    m.distance_to_goal += o.distance;
    m.path_length += o.path;
    m.steps += o.steps;
  }
  const double n = static_cast<double>(outcomes.size());
  m.success /= n;
  m.spl /= n;
  m.distance_to_goal /= n;
  m.path_length /= n;
  m.steps /= n;
  return m;
}

nlohmann::json metricsJson(const PointNavMetrics& m) {
  return {{"episodes", m.episodes},         {"success", m.success},
          {"spl", m.spl},                   {"distance_to_goal", m.distance_to_goal},
          {"path_length", m.path_length},   {"steps", m.steps}};
}

// The point-goal episodes of one rollout on the episode scheduler: who
// drives, what is recorded, how each episode ended.
struct RolloutSpec {
  Driver driver = Driver::kOracle;
  models::PointNavPolicyImpl* policy = nullptr;  // needed for kMixed and kPolicy
  double beta = 0.0;                     // kMixed: the follower's probability
  uint64_t seed = 0;                     // coins and random actions
  // with `record`, every step goes to (*record)[k] for episode k; the
  // recorded bytes plus `bytesBefore` must stay within `byteBudget`
  std::vector<RecordedEpisode>* record = nullptr;
  size_t bytesBefore = 0;
  size_t byteBudget = 0;
};

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
      const std::vector<float>& frame = observations[static_cast<size_t>(i)]->depth;
      std::copy(frame.begin(), frame.begin() + static_cast<std::ptrdiff_t>(pixels),
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
  auto [logits, next] = policy.forward(inputs, hidden.index_select(0, rowIndex));
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
      : config_(config), scenes_(scenes), episodes_(episodes), spec_(spec),
        envs_(envs), device_(device),
        // with beta = 1 the policy's actions are never taken: not run
        usePolicy_(spec.driver == Driver::kPolicy ||
                   (spec.driver == Driver::kMixed && spec.beta < 1.0)),
        needOracle_(spec.record != nullptr || spec.driver == Driver::kMixed ||
                    spec.driver == Driver::kOracle),
        depthScale_(config.sim.depth.normalize_depth ? 1.0f
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
      const PointGoalEpisode& ep = episodes_[static_cast<size_t>(
          running.episodes[running.indexOf(e)])];
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
        RecordedEpisode& rec = (*spec_.record)[static_cast<size_t>(running.episodes[i])];
        const size_t before = rec.bytes();
        rec.append(envs_.observation(running.envs[i]).depth, depthScale_, env.goal,
                   env.prev, env.oracle);
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
      outcomes_[index] = outcomeOf(
          ep, envs_.state(ended.envs[k]),
          state_[static_cast<size_t>(ended.envs[k])].path,
          scenes_[static_cast<size_t>(ep.house)]->navmesh(),
          config_.pretrain.success_distance);
      line_.advance();
    }
  }

 private:
  void checkBudget() const {
    VLN_CHECK_IO(recordedBytes_ <= spec_.byteBudget, "depth_pointnav: the aggregated DAgger "
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
  std::vector<PointGoalEnv> state_;                            // per environment
  torch::Tensor hidden_;                              // [environments, H]
  std::vector<Outcome> outcomes_;
  size_t recordedBytes_;
  common::ProgressLine line_;
};

// Runs `episodes` in `scenes` with trainer.num_envs environments on
// trainer.env_threads threads; returns their outcomes in order.
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

// ===========================================================================
// training batches
// ===========================================================================

struct Batch {
  models::PointNavInputs inputs;
  torch::Tensor labels;  // [T, B] int64
  torch::Tensor valid;   // [T, B] bool
  int64_t steps = 0;
};

Batch makeBatch(const std::vector<const RecordedEpisode*>& episodes,
                int64_t height, int64_t width, float depthScale,
                torch::Device device) {
  const int64_t batch = static_cast<int64_t>(episodes.size());
  int64_t steps = 0, frames = 0;
  for (const RecordedEpisode* e : episodes) {
    steps = std::max(steps, e->length());
    frames += e->length();
  }
  const int64_t pixels = height * width;
  torch::Tensor depth = torch::empty({frames, height, width, 1});
  torch::Tensor frameIndex = torch::empty({frames}, torch::kLong);
  torch::Tensor goal = torch::zeros({steps, batch, models::kPointGoalDims});
  torch::Tensor prev = torch::zeros({steps, batch}, torch::kLong);
  torch::Tensor notDone = torch::zeros({steps, batch});
  torch::Tensor labels = torch::zeros({steps, batch}, torch::kLong);
  torch::Tensor valid = torch::zeros({steps, batch}, torch::kBool);
  float* depthData = depth.data_ptr<float>();
  int64_t* indexData = frameIndex.data_ptr<int64_t>();
  auto goalA = goal.accessor<float, 3>();
  auto prevA = prev.accessor<int64_t, 2>();
  auto notDoneA = notDone.accessor<float, 2>();
  auto labelsA = labels.accessor<int64_t, 2>();
  auto validA = valid.accessor<bool, 2>();
  const float decode = depthScale / kDepthCodeMax;
  int64_t frame = 0;
  for (int64_t b = 0; b < batch; ++b) {
    const RecordedEpisode& e = *episodes[static_cast<size_t>(b)];
    for (int64_t t = 0; t < e.length(); ++t, ++frame) {
      const uint16_t* codes = e.depth.data() + t * pixels;
      float* out = depthData + frame * pixels;
      for (int64_t p = 0; p < pixels; ++p) out[p] = static_cast<float>(codes[p]) * decode;
      indexData[frame] = t * batch + b;
      for (int64_t k = 0; k < models::kPointGoalDims; ++k)
        goalA[t][b][k] = e.goal[static_cast<size_t>(t * models::kPointGoalDims + k)];
      prevA[t][b] = e.prev[static_cast<size_t>(t)];
      notDoneA[t][b] = t == 0 ? 0.0f : 1.0f;
      labelsA[t][b] = e.label[static_cast<size_t>(t)];
      validA[t][b] = true;
    }
  }
  Batch out;
  out.inputs.depth = depth.to(device);
  out.inputs.frame_index = frameIndex.to(device);
  out.inputs.goal = goal.to(device);
  out.inputs.prev_actions = prev.to(device);
  out.inputs.not_done = notDone.to(device);
  out.labels = labels.to(device);
  out.valid = valid.to(device);
  out.steps = frames;
  return out;
}

// total actions / inflections over the labels (VLN-CE's inverse inflection
// frequency; ImitationLearner.h)
double labelInflectionFrequency(const std::vector<RecordedEpisode>& episodes) {
  int64_t actions = 0, inflections = 0;
  for (const RecordedEpisode& e : episodes)
    for (int64_t t = 0; t < e.length(); ++t) {
      ++actions;
      if (t == 0 || e.label[static_cast<size_t>(t)] != e.label[static_cast<size_t>(t - 1)])
        ++inflections;
    }
  VLN_CHECK_ARG(inflections > 0, "depth_pointnav: no labelled steps to derive the inflection "
                "weight from (trainer.inflection_weight <= 0)");
  return static_cast<double>(actions) / static_cast<double>(inflections);
}

// One trained model with its optimizer and loss bookkeeping.
struct Learner {
  std::string name;
  models::PointNavPolicy policy{nullptr};
  std::unique_ptr<torch::optim::Adam> optimizer;
  NonFiniteLosses nonFinite;
  double epochLoss = 0.0;
  int64_t epochUpdates = 0;
};

}  // namespace

// ===========================================================================
// the pretrainer
// ===========================================================================

struct PointNavPretrainer::Impl : PretrainRun {
  Learner depthLearner, blindLearner;
  std::vector<RecordedEpisode> aggregate;
  size_t aggregateBytes = 0;
  double inflectionCoef = 0.0;
  float depthScale = 1.0f;

  double betaOf(int iteration) const {
    const double p = config.trainer.dagger_beta;
    if (p == 0.0) return 0.0;  // as the VLN trainer: 0^0 would be 1
    return std::pow(p, iteration);
  }

  size_t byteBudget() const {
    return static_cast<size_t>(config.pretrain.max_memory_gib * 1024.0 * 1024.0 * 1024.0);
  }

  // --- collection -------------------------------------------------------------

  void collect(int iteration) {
    const PretrainConfig& p = config.pretrain;
    const uint64_t seed = static_cast<uint64_t>(config.trainer.seed);
    const double beta = betaOf(iteration);
    const std::vector<PointGoalEpisode> episodes = samplePointGoalEpisodes(
        houses.train, p.samples, p.min_goal_distance, p.max_goal_distance,
        common::deriveSeed(seed, kTrainEpisodeStream + static_cast<uint64_t>(iteration)));
    std::vector<RecordedEpisode> recorded;
    RolloutSpec spec;
    spec.driver = Driver::kMixed;
    spec.policy = depthLearner.policy.get();
    spec.beta = beta;
    spec.seed = common::deriveSeed(seed, kCoinStream + static_cast<uint64_t>(iteration));
    spec.record = &recorded;
    spec.bytesBefore = aggregateBytes;
    spec.byteBudget = byteBudget();
    common::Stopwatch clock;
    const std::vector<Outcome> outcomes = runPointGoalEpisodes(
        config, houses.train, episodes, spec, device,
        "collect iteration " + std::to_string(iteration));
    const double seconds = clock.seconds();
    int64_t frames = 0;
    for (RecordedEpisode& e : recorded) {
      frames += e.length();
      aggregateBytes += e.bytes();
      aggregate.push_back(std::move(e));
    }
    int64_t totalFrames = 0;
    for (const RecordedEpisode& e : aggregate) totalFrames += e.length();
    const PointNavMetrics m = summarise(outcomes);
    const double gib = static_cast<double>(aggregateBytes) / (1024.0 * 1024.0 * 1024.0);
    spdlog::info("iteration {}: beta {:.3f}, {} episodes, {} frames in {:.1f} s ({:.0f} frames/s); "
                 "success of the mixed driver {:.3f}; aggregate {} episodes, {} frames, {:.3f} GiB",
                 iteration, beta, episodes.size(), frames, seconds,
                 seconds > 0 ? static_cast<double>(frames) / seconds : 0.0, m.success,
                 aggregate.size(), totalFrames, gib);
    metrics->write("collect",
                   {{"iteration", iteration}, {"beta", beta},
                    {"episodes", static_cast<int64_t>(episodes.size())}, {"frames", frames},
                    {"seconds", seconds}, {"driver_success", m.success},
                    {"aggregate_episodes", static_cast<int64_t>(aggregate.size())},
                    {"aggregate_frames", totalFrames}, {"aggregate_gib", gib}},
                   {{"collect/beta", beta},
                    {"collect/driver_success", m.success},
                    {"collect/aggregate_frames", static_cast<double>(totalFrames)}},
                   iteration);
  }

  // --- training ---------------------------------------------------------------

  // one update of `learner` on `batch`; returns the loss (NaN when skipped)
  double update(Learner& learner, const Batch& batch, bool withDepth) {
    learner.policy->train();
    models::PointNavInputs inputs = batch.inputs;
    if (!withDepth) {
      inputs.depth = torch::Tensor();
      inputs.frame_index = torch::Tensor();
    }
    const int64_t episodes = batch.labels.size(1);
    auto [logits, last] = learner.policy->forward(inputs, learner.policy->initialHidden(episodes));
    const torch::Tensor weights =
        models::inflectionWeights(batch.labels, batch.valid, inflectionCoef);
    const torch::Tensor loss = models::weightedActionLoss(logits, batch.labels, weights);
    const double value = loss.item<double>();
    if (!std::isfinite(value)) {
      learner.nonFinite.skip(config, "depth_pointnav", learner.name, updates);
      return std::numeric_limits<double>::quiet_NaN();
    }
    learner.nonFinite.inARow = 0;
    applyUpdate(*learner.optimizer, *learner.policy, loss, config.trainer.grad_clip);
    learner.epochLoss += value;
    ++learner.epochUpdates;
    return value;
  }

  void trainEpoch(int iteration, int epoch) {
    const PretrainConfig& p = config.pretrain;
    const std::vector<int64_t> order = shuffledOrder(
        aggregate.size(),
        kEpochStream + static_cast<uint64_t>(iteration) * 1000u + static_cast<uint64_t>(epoch));
    const size_t batchSize = static_cast<size_t>(p.batch_size);
    const int64_t batches = static_cast<int64_t>((order.size() + batchSize - 1) / batchSize);
    for (Learner* l : {&depthLearner, &blindLearner}) {
      l->epochLoss = 0.0;
      l->epochUpdates = 0;
    }
    common::ProgressLine line(
        "train iteration " + std::to_string(iteration) + " epoch " + std::to_string(epoch),
        batches, "updates");
    common::Stopwatch clock;
    int64_t frames = 0;
    for (size_t first = 0; first < order.size(); first += batchSize) {
      std::vector<const RecordedEpisode*> episodes;
      for (size_t k = first; k < std::min(order.size(), first + batchSize); ++k)
        episodes.push_back(&aggregate[static_cast<size_t>(order[k])]);
      const Batch batch = makeBatch(episodes, config.sim.depth.camera.height,
                                    config.sim.depth.camera.width, depthScale, device);
      frames += batch.steps;
      const double loss = update(depthLearner, batch, /*withDepth=*/true);
      const double blindLoss = update(blindLearner, batch, /*withDepth=*/false);
      if (std::isnan(initialLoss)) initialLoss = loss;
      ++updates;
      line.advance();
      if (updates % config.trainer.log_every_updates == 0)
        metrics->write("update",
                       {{"update", updates}, {"iteration", iteration}, {"epoch", epoch},
                        {"loss", loss}, {"blind_loss", blindLoss}, {"steps", batch.steps}},
                       {{"train/loss", loss}, {"train/blind_loss", blindLoss}}, updates);
    }
    const double seconds = clock.seconds();
    const double loss = depthLearner.epochLoss / std::max<int64_t>(1, depthLearner.epochUpdates);
    const double blindLoss =
        blindLearner.epochLoss / std::max<int64_t>(1, blindLearner.epochUpdates);
    spdlog::info("iteration {} epoch {}: {} updates in {:.1f} s ({:.0f} frames/s), mean loss "
                 "{:.4f} (blind control {:.4f})",
                 iteration, epoch, batches, seconds,
                 seconds > 0 ? static_cast<double>(frames) / seconds : 0.0, loss, blindLoss);
    metrics->write("epoch",
                   {{"iteration", iteration}, {"epoch", epoch}, {"updates", batches},
                    {"seconds", seconds}, {"frames", frames}, {"loss", loss},
                    {"blind_loss", blindLoss},
                    {"skipped", depthLearner.nonFinite.total + blindLearner.nonFinite.total}},
                   {{"epoch/loss", loss}, {"epoch/blind_loss", blindLoss}}, updates);
  }

  // --- evaluation -------------------------------------------------------------

  PointNavMetrics evaluate(const std::vector<PointGoalEpisode>& episodes, Driver driver,
                           models::PointNavPolicyImpl* policy, const std::string& name) {
    RolloutSpec spec;
    spec.driver = driver;
    spec.policy = policy;
    spec.seed = common::deriveSeed(static_cast<uint64_t>(config.trainer.seed), kEvalCoinStream);
    const std::vector<Outcome> outcomes =
        runPointGoalEpisodes(config, houses.heldout, episodes, spec, device, "evaluate " + name);
    const PointNavMetrics m = summarise(outcomes);
    spdlog::info("held-out {}: {} episodes, success {:.3f}, SPL {:.3f}, distance to goal {:.2f} m, "
                 "path {:.2f} m, {:.1f} steps",
                 name, m.episodes, m.success, m.spl, m.distance_to_goal, m.path_length, m.steps);
    nlohmann::json record = metricsJson(m);
    record["agent"] = name;
    metrics->write("eval", record,
                   {{"eval/" + name + "/success", m.success}, {"eval/" + name + "/spl", m.spl}},
                   updates);
    return m;
  }
};

PointNavPretrainer::PointNavPretrainer(const ExperimentConfig& config, fs::path runDir)
    : impl_(std::make_unique<Impl>()) {
  Impl& s = *impl_;
  s.start(config, std::move(runDir), "depth_pointnav", "PointNavPretrainer");
  s.depthScale = config.sim.depth.normalize_depth ? 1.0f : config.sim.depth.max_depth;

  // the two learners: same architecture but for the depth input
  const int64_t hidden = config.pretrain.hidden_size;
  s.depthLearner.name = "depth policy";
  s.depthLearner.policy = models::PointNavPolicy(config.model, hidden, /*useDepth=*/true);
  if (!config.model.depth_weights.empty()) {
    models::loadModule(s.depthLearner.policy->depth->cnnModule(), config.model.depth_weights);
    spdlog::info("depth CNN initialised from {}", config.model.depth_weights);
  }
  s.blindLearner.name = "blind control";
  s.blindLearner.policy = models::PointNavPolicy(config.model, hidden, /*useDepth=*/false);
  for (Learner* l : {&s.depthLearner, &s.blindLearner}) {
    l->policy->to(s.device);
    l->optimizer = std::make_unique<torch::optim::Adam>(
        l->policy->parameters(), torch::optim::AdamOptions(config.pretrain.lr));
    spdlog::info("{}: {} parameters", l->name, parameterCount(*l->policy));
  }
  s.openMetrics();
}

PointNavPretrainer::~PointNavPretrainer() = default;

PointNavResult PointNavPretrainer::run() {
  Impl& s = *impl_;
  const ExperimentConfig& config = s.config;
  const PretrainConfig& p = config.pretrain;
  common::Stopwatch clock;

  // DAgger: collect, aggregate, train
  for (int n = 0; n < p.iterations; ++n) {
    s.collect(n);
    if (n == 0) {
      s.inflectionCoef = config.trainer.inflection_weight > 0.0
                             ? config.trainer.inflection_weight
                             : labelInflectionFrequency(s.aggregate);
      spdlog::info("inflection weight {:.3f}{}", s.inflectionCoef,
                   config.trainer.inflection_weight > 0.0
                       ? ""
                       : " (inverse inflection frequency of iteration 0)");
    }
    for (int e = 0; e < p.epochs_per_iteration; ++e) s.trainEpoch(n, e);
  }

  // held-out evaluation: the policy, the blind control, the random agent
  // and the follower on the same episodes
  const std::vector<PointGoalEpisode> heldout = samplePointGoalEpisodes(
      s.houses.heldout, p.eval_samples, p.min_goal_distance, p.max_goal_distance,
      common::deriveSeed(static_cast<uint64_t>(config.trainer.seed), kEvalEpisodeStream));
  PointNavResult result;
  result.policy = s.evaluate(heldout, Driver::kPolicy, s.depthLearner.policy.get(), "policy");
  result.blind = s.evaluate(heldout, Driver::kPolicy, s.blindLearner.policy.get(), "blind");
  result.random = s.evaluate(heldout, Driver::kRandom, nullptr, "random");
  result.oracle = s.evaluate(heldout, Driver::kOracle, nullptr, "follower");
  result.initial_loss = s.initialLoss;
  result.final_loss =
      s.depthLearner.epochLoss / std::max<int64_t>(1, s.depthLearner.epochUpdates);
  result.blind_final_loss =
      s.blindLearner.epochLoss / std::max<int64_t>(1, s.blindLearner.epochUpdates);
  result.inflection_coef = s.inflectionCoef;
  for (const RecordedEpisode& e : s.aggregate) result.frames += e.length();
  result.memory_gib = static_cast<double>(s.aggregateBytes) / (1024.0 * 1024.0 * 1024.0);

  // the encoder a VLN config loads with model.depth_weights, and the whole
  // policy for inspection
  s.depthLearner.policy->to(torch::kCPU);
  result.encoder_file = encoderOutputPath(config, s.runDir, "depth_encoder.pt");
  models::saveModule(s.depthLearner.policy->depth->cnnModule(), result.encoder_file);
  models::saveModule(*s.depthLearner.policy, s.runDir / "pointnav_policy.pt");
  result.seconds = clock.seconds();
  spdlog::info("depth_pointnav done in {:.1f} s: held-out SPL {:.3f} (blind {:.3f}, random {:.3f}, "
               "follower {:.3f}); depth encoder saved to {}",
               result.seconds, result.policy.spl, result.blind.spl, result.random.spl,
               result.oracle.spl, result.encoder_file.string());

  nlohmann::json summary = s.summary("depth_pointnav", result.seconds);
  summary.update({
      {"success_distance", p.success_distance},
      {"goal_distance_range", {p.min_goal_distance, p.max_goal_distance}},
      {"iterations", p.iterations},
      {"episodes_per_iteration", p.samples},
      {"epochs_per_iteration", p.epochs_per_iteration},
      {"aggregate_frames", result.frames},
      {"aggregate_gib", result.memory_gib},
      {"inflection_coef", result.inflection_coef},
      {"initial_loss", result.initial_loss},
      {"final_loss", result.final_loss},
      {"blind_final_loss", result.blind_final_loss},
      {"nonfinite_updates", s.depthLearner.nonFinite.total + s.blindLearner.nonFinite.total},
      {"depth_encoder", models::encoderName(config.model.depth_encoder)},
      {"depth_size", {config.model.depth_width, config.model.depth_height}},
      {"encoder_file", result.encoder_file.string()},
      {"heldout",
       {{"policy", metricsJson(result.policy)},
        {"blind", metricsJson(result.blind)},
        {"random", metricsJson(result.random)},
        {"follower", metricsJson(result.oracle)}}}});
  s.finish(summary, {{"final/spl", result.policy.spl}, {"final/blind_spl", result.blind.spl}});
  return result;
}

}  // namespace vln::train
