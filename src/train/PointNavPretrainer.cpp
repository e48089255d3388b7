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
#include "sim/Simulator.h"
#include "train/MetricsLog.h"
#include "train/PretrainCommon.h"
#include "train/PretrainTasks.h"

namespace vln::train {
namespace fs = std::filesystem;

namespace {

// DD-PPO's goal and previous-action embedding widths
// (habitat_baselines PointNavResNetNet: tgt_embeding and
// prev_action_embedding are both 32 wide)
constexpr int64_t kGoalEmbeddingDim = 32;
constexpr int64_t kPrevActionEmbeddingDim = 32;
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

// ===========================================================================
// the policy
// ===========================================================================

PointNavPolicyImpl::PointNavPolicyImpl(const models::ModelConfig& model,
                                       int64_t hiddenSize, bool useDepth)
    : hiddenSize_(hiddenSize) {
  int64_t inputSize = kGoalEmbeddingDim + kPrevActionEmbeddingDim;
  if (useDepth) {
    depth = register_module("depth", models::DepthEncoder(model));
    const models::FeatureShape shape = models::depthFeatureShape(model);
    depth_fc = register_module(
        "depth_fc", torch::nn::Linear(shape[0] * shape[1] * shape[2],
                                      model.depth_projection_size));
    inputSize += model.depth_projection_size;
  }
  goal_embedding = register_module(
      "goal_embedding", torch::nn::Linear(kPointGoalDims, kGoalEmbeddingDim));
  // index 0 is "episode start", actions are shifted by one (VLN-CE, DD-PPO)
  prev_action_embedding = register_module(
      "prev_action_embedding",
      torch::nn::Embedding(models::kNumActions + 1, kPrevActionEmbeddingDim));
  gru = register_module("gru", models::MaskedGru(inputSize, hiddenSize));
  action = register_module("action",
                           torch::nn::Linear(hiddenSize, models::kNumActions));
  // habitat's CategoricalNet: near-uniform initial action distribution
  torch::NoGradGuard noGrad;
  torch::nn::init::orthogonal_(action->weight, /*gain=*/0.01);
  torch::nn::init::zeros_(action->bias);
}

std::pair<torch::Tensor, torch::Tensor> PointNavPolicyImpl::forward(
    const PointNavInputs& inputs, const torch::Tensor& hidden) {
  TORCH_CHECK(inputs.goal.dim() == 3 && inputs.goal.size(2) == kPointGoalDims,
              "PointNavPolicy::forward(): expected goal [T, B, 3], got ",
              inputs.goal.sizes());
  const int64_t steps = inputs.goal.size(0), batch = inputs.goal.size(1);
  TORCH_CHECK(inputs.prev_actions.sizes() == inputs.not_done.sizes() &&
                  inputs.prev_actions.dim() == 2 &&
                  inputs.prev_actions.size(0) == steps &&
                  inputs.prev_actions.size(1) == batch,
              "PointNavPolicy::forward(): expected prev_actions and not_done "
              "[T, B] = [",
              steps, ", ", batch, "], got ", inputs.prev_actions.sizes(),
              " and ", inputs.not_done.sizes());
  TORCH_CHECK(hidden.dim() == 2 && hidden.size(0) == batch &&
                  hidden.size(1) == hiddenSize_,
              "PointNavPolicy::forward(): expected hidden [", batch, ", ",
              hiddenSize_, "], got ", hidden.sizes());

  std::vector<torch::Tensor> parts;
  if (depth) {
    TORCH_CHECK(inputs.depth.defined() && inputs.frame_index.defined() &&
                    inputs.frame_index.dim() == 1 &&
                    inputs.depth.size(0) == inputs.frame_index.size(0),
                "PointNavPolicy::forward(): expected depth [N, H, W, 1] and "
                "frame_index [N], got ",
                inputs.depth.defined() ? inputs.depth.sizes()
                                       : torch::IntArrayRef{},
                " and ",
                inputs.frame_index.defined() ? inputs.frame_index.sizes()
                                             : torch::IntArrayRef{});
    // the CNN runs on the real frames only, then they go to their (t, b)
    const torch::Tensor features =
        torch::relu(depth_fc->forward(depth->forward(inputs.depth).flatten(1)));
    const torch::Tensor placed =
        torch::zeros({steps * batch, features.size(1)}, features.options())
            .index_copy(0, inputs.frame_index, features);
    parts.push_back(placed.view({steps, batch, -1}));
  }
  parts.push_back(goal_embedding->forward(inputs.goal));
  const torch::Tensor prevIndex =
      (inputs.prev_actions + 1) * inputs.not_done.to(torch::kLong);
  parts.push_back(prev_action_embedding->forward(prevIndex));

  auto [out, last] = gru->forward(torch::cat(parts, /*dim=*/-1), hidden,
                                  inputs.not_done);
  return {action->forward(out), last};
}

torch::Tensor PointNavPolicyImpl::initialHidden(int64_t batch) const {
  return torch::zeros({batch, hiddenSize_},
                      action->weight.options().requires_grad(false));
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

// Steps trainer.num_envs episodes at a time over a list of episodes, on a
// thread pool (rendering, follower queries and moves run in parallel; the
// policy runs batched on the calling thread).
class EpisodeRunner {
 public:
  EpisodeRunner(const ExperimentConfig& config,
                const std::vector<std::shared_ptr<const sim::Scene>>& scenes,
                common::ThreadPool& pool, torch::Device device)
      : config_(config), scenes_(scenes), pool_(pool), device_(device) {
    for (const auto& scene : scenes_)
      followers_.emplace_back(scene->navmesh(), config_.sim.agent,
                              config_.pretrain.success_distance);
    depthScale_ =
        config_.sim.depth.normalize_depth ? 1.0f : config_.sim.depth.max_depth;
  }

  // Runs `episodes`; returns their outcomes in order. `policy` is needed
  // for kMixed and kPolicy. With `record`, every step is recorded into
  // (*record)[k] for episode k; the recorded bytes plus `bytesBefore` must
  // stay within `byteBudget`.
  std::vector<Outcome> run(const std::vector<PointGoalEpisode>& episodes,
                           Driver driver, PointNavPolicyImpl* policy,
                           double beta, uint64_t seed,
                           std::vector<RecordedEpisode>* record,
                           size_t bytesBefore, size_t byteBudget,
                           const std::string& label) {
    // with beta = 1 the policy's actions are never taken, so it is not run
    const bool usePolicy =
        driver == Driver::kPolicy || (driver == Driver::kMixed && beta < 1.0);
    VLN_ASSERT(!usePolicy || policy != nullptr);
    const bool render = record != nullptr || (usePolicy && policy->usesDepth());
    const bool needOracle =
        record != nullptr || driver == Driver::kMixed || driver == Driver::kOracle;
    const int64_t width = config_.sim.depth.camera.width;
    const int64_t height = config_.sim.depth.camera.height;
    const size_t pixels = static_cast<size_t>(width * height);

    std::vector<Outcome> outcomes(episodes.size());
    if (record != nullptr) record->assign(episodes.size(), RecordedEpisode{});
    const size_t envCount = std::min(
        episodes.size(), static_cast<size_t>(config_.trainer.num_envs));
    std::vector<Env> envs(envCount);
    torch::Tensor hidden;
    if (usePolicy) {
      policy->eval();
      hidden = policy->initialHidden(static_cast<int64_t>(envCount));
    }
    size_t nextEpisode = 0;
    size_t recordedBytes = bytesBefore;
    std::vector<int> active;
    for (size_t e = 0; e < envCount; ++e) {
      start(envs[e], episodes, nextEpisode++, seed);
      active.push_back(static_cast<int>(e));
    }
    common::ProgressLine line(label, static_cast<int64_t>(episodes.size()),
                              "episodes");
    std::vector<sim::Action> actions;
    while (!active.empty()) {
      // sensors, the follower's action and the depth frame
      pool_.parallelFor(active.size(), [&](size_t i) {
        Env& env = envs[static_cast<size_t>(active[i])];
        const PointGoalEpisode& ep = episodes[env.episode];
        const sim::AgentState& agent = env.sim->episode().agent;
        env.goal = pointGoalObservation(agent, ep.goal);
        if (needOracle)
          env.oracle = followers_[static_cast<size_t>(ep.house)].nextAction(
              agent, ep.goal);
        if (render) env.sim->observe(env.obs);
      });

      // the policy, batched over the active environments
      std::vector<int64_t> policyActions;
      if (usePolicy) policyActions = act(*policy, envs, active, hidden, pixels);

      // pick and record the actions
      actions.assign(active.size(), sim::Action::kStop);
      for (size_t i = 0; i < active.size(); ++i) {
        Env& env = envs[static_cast<size_t>(active[i])];
        switch (driver) {
          case Driver::kMixed: {
            const bool takeOracle = common::uniform01(env.rng) < beta;
            actions[i] = takeOracle || !usePolicy
                             ? env.oracle
                             : sim::actionFromInt(static_cast<int>(policyActions[i]));
            break;
          }
          case Driver::kPolicy:
            actions[i] = sim::actionFromInt(static_cast<int>(policyActions[i]));
            break;
          case Driver::kRandom:
            actions[i] = env.goal[0] <= config_.pretrain.success_distance
                             ? sim::Action::kStop
                             : sim::actionFromInt(1 + common::uniformIndex(env.rng, 3));
            break;
          case Driver::kOracle:
            actions[i] = env.oracle;
            break;
        }
        if (record != nullptr) {
          RecordedEpisode& rec = (*record)[env.episode];
          const size_t before = rec.bytes();
          const size_t offset = rec.depth.size();
          rec.depth.resize(offset + pixels);
          for (size_t p = 0; p < pixels; ++p) {
            const float v = std::clamp(env.obs.depth[p] / depthScale_, 0.0f, 1.0f);
            rec.depth[offset + p] =
                static_cast<uint16_t>(std::lround(v * kDepthCodeMax));
          }
          rec.goal.insert(rec.goal.end(), env.goal.begin(), env.goal.end());
          rec.prev.push_back(static_cast<int8_t>(env.prev));
          rec.label.push_back(static_cast<int8_t>(env.oracle));
          recordedBytes += rec.bytes() - before;
        }
      }
      if (record != nullptr) checkBudget(recordedBytes, byteBudget);

      // move
      pool_.parallelFor(active.size(), [&](size_t i) {
        Env& env = envs[static_cast<size_t>(active[i])];
        const sim::StepResult result = env.sim->step(actions[i]);
        env.path += result.distance;
        env.prev = static_cast<int>(actions[i]);
        env.first = false;
      });

      // finished episodes hand their environment to the next one
      std::vector<int> still;
      for (int e : active) {
        Env& env = envs[static_cast<size_t>(e)];
        if (!env.sim->episode().done) {
          still.push_back(e);
          continue;
        }
        outcomes[env.episode] = finish(env, episodes[env.episode]);
        line.advance();
        if (nextEpisode < episodes.size()) {
          start(env, episodes, nextEpisode++, seed);
          still.push_back(e);
        }
      }
      active = std::move(still);
    }
    return outcomes;
  }

 private:
  struct Env {
    std::unique_ptr<sim::Simulator> sim;
    int house = -1;
    size_t episode = 0;
    std::mt19937_64 rng;
    int prev = 0;
    bool first = true;
    double path = 0.0;
    std::array<float, 3> goal{};
    sim::Action oracle = sim::Action::kStop;
    sim::Observation obs;
  };

  void start(Env& env, const std::vector<PointGoalEpisode>& episodes,
             size_t index, uint64_t seed) {
    const PointGoalEpisode& ep = episodes[index];
    const auto& scene = scenes_[static_cast<size_t>(ep.house)];
    if (!env.sim) {
      env.sim = std::make_unique<sim::Simulator>(scene, config_.sim, config_.task);
    } else if (env.house != ep.house) {
      env.sim->setScene(scene);
    }
    env.house = ep.house;
    env.episode = index;
    env.sim->reset(ep.start);
    // episode k's coins and random actions are its own: the result does
    // not depend on which environment runs it
    env.rng.seed(common::deriveSeed(seed, static_cast<uint64_t>(index)));
    env.prev = 0;
    env.first = true;
    env.path = 0.0;
  }

  Outcome finish(const Env& env, const PointGoalEpisode& ep) const {
    const sim::EpisodeState& state = env.sim->episode();
    Outcome o;
    o.distance = scenes_[static_cast<size_t>(ep.house)]->navmesh().geodesicDistance(
        state.agent.position, ep.goal);
    o.success = state.called_stop && o.distance <= config_.pretrain.success_distance;
    o.path = env.path;
    o.steps = state.steps;
    const double d0 = ep.geodesic_distance;
    o.spl = o.success ? d0 / std::max(d0, o.path) : 0.0;
    return o;
  }

  // argmax actions of `policy` for the active environments, one step
  std::vector<int64_t> act(PointNavPolicyImpl& policy, std::vector<Env>& envs,
                           const std::vector<int>& active, torch::Tensor& hidden,
                           size_t pixels) {
    torch::NoGradGuard noGrad;
    const int64_t n = static_cast<int64_t>(active.size());
    const int64_t width = config_.sim.depth.camera.width;
    const int64_t height = config_.sim.depth.camera.height;
    std::vector<float> goal(static_cast<size_t>(n) * kPointGoalDims);
    std::vector<int64_t> prev(static_cast<size_t>(n)), rows(static_cast<size_t>(n));
    std::vector<float> notDone(static_cast<size_t>(n));
    torch::Tensor depth;
    if (policy.usesDepth()) depth = torch::empty({n, height, width, 1});
    for (int64_t i = 0; i < n; ++i) {
      const Env& env = envs[static_cast<size_t>(active[static_cast<size_t>(i)])];
      std::copy(env.goal.begin(), env.goal.end(),
                goal.begin() + i * kPointGoalDims);
      prev[static_cast<size_t>(i)] = env.prev;
      notDone[static_cast<size_t>(i)] = env.first ? 0.0f : 1.0f;
      rows[static_cast<size_t>(i)] = active[static_cast<size_t>(i)];
      if (depth.defined())
        std::copy(env.obs.depth.begin(), env.obs.depth.begin() + pixels,
                  depth.data_ptr<float>() + i * static_cast<int64_t>(pixels));
    }
    PointNavInputs inputs;
    if (depth.defined()) {
      inputs.depth = depth.to(device_);
      inputs.frame_index = torch::arange(n, torch::TensorOptions(torch::kLong).device(device_));
    }
    inputs.goal = torch::from_blob(goal.data(), {1, n, kPointGoalDims}).to(device_);
    inputs.prev_actions = torch::from_blob(prev.data(), {1, n}, torch::kLong).to(device_);
    inputs.not_done = torch::from_blob(notDone.data(), {1, n}).to(device_);
    const torch::Tensor rowIndex =
        torch::from_blob(rows.data(), {n}, torch::kLong).to(device_);
    auto [logits, next] = policy.forward(inputs, hidden.index_select(0, rowIndex));
    hidden.index_copy_(0, rowIndex, next);
    const torch::Tensor best = logits[0].argmax(-1).to(torch::kCPU).contiguous();
    return std::vector<int64_t>(best.data_ptr<int64_t>(), best.data_ptr<int64_t>() + n);
  }

  void checkBudget(size_t bytes, size_t budget) const {
    VLN_CHECK_IO(bytes <= budget, "depth_pointnav: the aggregated DAgger frames need more than "
                 "pretrain.max_memory_gib = ", config_.pretrain.max_memory_gib,
                 " GiB; lower pretrain.samples, pretrain.iterations or "
                 "task.max_episode_steps, or raise pretrain.max_memory_gib");
  }

  const ExperimentConfig& config_;
  const std::vector<std::shared_ptr<const sim::Scene>>& scenes_;
  common::ThreadPool& pool_;
  torch::Device device_;
  std::vector<sim::ShortestPathFollower> followers_;
  float depthScale_ = 1.0f;
};

// ===========================================================================
// training batches
// ===========================================================================

struct Batch {
  PointNavInputs inputs;
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
  torch::Tensor goal = torch::zeros({steps, batch, kPointGoalDims});
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
      for (int64_t k = 0; k < kPointGoalDims; ++k)
        goalA[t][b][k] = e.goal[static_cast<size_t>(t * kPointGoalDims + k)];
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
  PointNavPolicy policy{nullptr};
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
    EpisodeRunner runner(config, houses.train, *pool, device);
    std::vector<RecordedEpisode> recorded;
    common::Stopwatch clock;
    const std::vector<Outcome> outcomes = runner.run(
        episodes, Driver::kMixed, depthLearner.policy.get(), beta,
        common::deriveSeed(seed, kCoinStream + static_cast<uint64_t>(iteration)), &recorded,
        aggregateBytes, byteBudget(), "collect iteration " + std::to_string(iteration));
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
    PointNavInputs inputs = batch.inputs;
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
                           PointNavPolicyImpl* policy, const std::string& name) {
    EpisodeRunner runner(config, houses.heldout, *pool, device);
    const std::vector<Outcome> outcomes = runner.run(
        episodes, driver, policy, /*beta=*/0.0,
        common::deriveSeed(static_cast<uint64_t>(config.trainer.seed), kEvalCoinStream), nullptr,
        0, 0, "evaluate " + name);
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
  s.depthLearner.policy = PointNavPolicy(config.model, hidden, /*useDepth=*/true);
  if (!config.model.depth_weights.empty()) {
    models::loadModule(s.depthLearner.policy->depth->cnnModule(), config.model.depth_weights);
    spdlog::info("depth CNN initialised from {}", config.model.depth_weights);
  }
  s.blindLearner.name = "blind control";
  s.blindLearner.policy = PointNavPolicy(config.model, hidden, /*useDepth=*/false);
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
