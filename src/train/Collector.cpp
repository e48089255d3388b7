#include "train/Collector.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>

#include "common/Check.h"
#include "common/Progress.h"
#include "common/Random.h"
#include "data/Vocabulary.h"
#include "eval/ObservationBatch.h"

namespace vln::train {

// ---------------------------------------------------------------------------
// oracle and progress

WaypointOracle::WaypointOracle(const sim::NavMesh& navmesh,
                               const sim::AgentConfig& agent, float goalRadius,
                               std::vector<Vec3f> waypoints)
    : follower_(navmesh, agent, goalRadius), waypoints_(std::move(waypoints)) {
  VLN_CHECK_ARG(!waypoints_.empty(),
                "WaypointOracle: an episode needs at least one waypoint");
  // waypoint 0 is the start: the first leg heads for waypoint 1
  current_ = std::min<int>(1, static_cast<int>(waypoints_.size()) - 1);
}

sim::Action WaypointOracle::next(const sim::AgentState& state) {
  const int last = static_cast<int>(waypoints_.size()) - 1;
  // a leg ends where the follower would stop at its waypoint; the next leg
  // starts from the same state, as the ground truth was generated
  while (current_ < last) {
    const sim::Action action =
        follower_.nextAction(state, waypoints_[static_cast<size_t>(current_)]);
    if (action != sim::Action::kStop) return action;
    ++current_;
  }
  return follower_.nextAction(state, waypoints_[static_cast<size_t>(last)]);
}

float progressTarget(float startDistance, float distance) {
  if (!std::isfinite(distance) || !std::isfinite(startDistance) ||
      startDistance <= 0.0f)
    return 0.0f;
  return std::clamp((startDistance - distance) / startDistance, -1.0f, 1.0f);
}

// ---------------------------------------------------------------------------
// collection

/// One environment's episode in progress.
struct Collector::Slot {
  int32_t slot = -1;
  const data::Episode* episode = nullptr;
  uint8_t source = 0;
  std::unique_ptr<WaypointOracle> oracle;
  std::mt19937_64 coins;
  float startDistance = 0.0f;
  Vec3f goal = Vec3f::Zero();
  torch::Tensor hidden;  ///< [layers, H] policy state (beta < 1)
  /// this episode's instruction alone (trainer.exact_resume, beta < 1)
  models::EncodedInstruction instruction;
  int64_t prevAction = 0;
  std::vector<torch::Tensor> rgb,
      depth;  ///< per step [C, h, w] in the store dtype
  std::vector<uint8_t> prevActions, oracleActions;
  std::vector<float> progress;
  int64_t oracleSteps = 0;
};

Collector::Collector(const ExperimentConfig& config,
                     std::shared_ptr<eval::SceneCache> scenes,
                     models::ObservationEncoder encoder)
    : config_(config),
      scenes_(std::move(scenes)),
      encoder_(std::move(encoder)) {
  envs_ = std::make_unique<eval::VectorEnv>(config_.trainer.num_envs,
                                            config_.sim, config_.task, scenes_,
                                            config_.trainer.env_threads);
}

Collector::~Collector() = default;

models::VisualFeatures Collector::encode(const eval::ObservationBatch& obs,
                                         torch::Device device) {
  auto on = [&](const torch::Tensor& t) {
    return t.defined() ? t.to(device) : t;
  };
  if (!config_.trainer.exact_resume)
    return encoder_->forward(on(obs.rgb), on(obs.depth));
  // one image at a time: batched convolutions and matrix products round
  // differently for other batch shapes
  const int64_t n = obs.rgb.defined() ? obs.rgb.size(0) : obs.depth.size(0);
  std::vector<torch::Tensor> rgb, depth;
  for (int64_t k = 0; k < n; ++k) {
    auto row = [&](const torch::Tensor& t) {
      return t.defined() ? on(t.slice(0, k, k + 1)) : t;
    };
    models::VisualFeatures f = encoder_->forward(row(obs.rgb), row(obs.depth));
    if (f.rgb.defined()) rgb.push_back(f.rgb);
    if (f.depth.defined()) depth.push_back(f.depth);
  }
  models::VisualFeatures features;
  if (!rgb.empty()) features.rgb = torch::cat(rgb);
  if (!depth.empty()) features.depth = torch::cat(depth);
  return features;
}

CollectionStats Collector::collect(
    const CollectionRound& round, FeatureStore& store,
    models::PolicyImpl* policy, const data::GroundTruth* groundTruth,
    const std::function<void(int64_t, int64_t)>& progress) {
  VLN_CHECK_ARG(round.sources.size() == round.episodes.size(),
                "Collector::collect(): ", round.sources.size(), " sources for ",
                round.episodes.size(), " slots");
  const bool usePolicy = round.beta < 1.0;
  VLN_CHECK_ARG(!usePolicy || policy != nullptr,
                "Collector::collect(): beta = ", round.beta,
                " < 1 needs a policy");
  const models::ModelConfig& model = config_.model;
  const torch::Device device = models::modelDevice(model);
  const torch::Dtype storeType =
      store.layout().fp16 ? torch::kHalf : torch::kFloat32;
  const bool exact = config_.trainer.exact_resume;
  torch::NoGradGuard noGrad;
  encoder_->eval();
  if (policy) policy->eval();

  CollectionStats stats;
  common::Stopwatch clock;
  VLN_CHECK_ARG(round.num_shards >= 1 && round.shard >= 0 &&
                    round.shard < round.num_shards,
                "Collector::collect(): shard ", round.shard, " of ",
                round.num_shards, " does not exist");
  // the slots of this shard still missing from the store, in round order
  const std::set<int32_t> done = store.slots(round.iteration);
  std::vector<int32_t> pending;
  size_t mine = 0;
  for (int32_t k = 0; k < static_cast<int32_t>(round.episodes.size()); ++k) {
    if (k % round.num_shards != round.shard) continue;
    ++mine;
    if (!done.count(k)) pending.push_back(k);
  }
  stats.skipped = static_cast<int64_t>(mine - pending.size());
  if (pending.empty()) return stats;
  if (stats.skipped > 0)
    spdlog::info(
        "collection round {}: {} of {} episodes already in the store, "
        "collecting {}",
        round.iteration, stats.skipped, mine, pending.size());

  const int numEnvs = envs_->size();
  std::vector<std::unique_ptr<Slot>> slots(static_cast<size_t>(numEnvs));
  size_t nextPending = 0;
  common::ProgressLine line(
      strCat("collect round ", round.iteration, " (beta ", round.beta, ")"),
      static_cast<int64_t>(pending.size()), "episodes");
  int64_t stored = 0;
  int64_t frames = 0;

  // starts the next pending slots in the free environments
  auto assign = [&](const std::vector<int>& freeEnvs) {
    std::vector<int> started;
    std::vector<const data::Episode*> episodes;
    for (int env : freeEnvs) {
      if (nextPending >= pending.size()) break;
      const int32_t k = pending[nextPending++];
      auto s = std::make_unique<Slot>();
      s->slot = k;
      s->episode = round.episodes[static_cast<size_t>(k)];
      s->source = round.sources[static_cast<size_t>(k)];
      s->coins.seed(common::deriveSeed(
          common::deriveSeed(round.seed,
                           1000003u + static_cast<uint64_t>(round.iteration)),
          static_cast<uint64_t>(k)));
      VLN_CHECK_ARG(
          !s->episode->reference_path.empty() && !s->episode->goals.empty(),
          "Collector: episode ", s->episode->episode_id,
          " has no reference_path or goals (a test split cannot be collected)");
      slots[static_cast<size_t>(env)] = std::move(s);
      started.push_back(env);
      episodes.push_back(slots[static_cast<size_t>(env)]->episode);
    }
    if (started.empty()) return;
    envs_->reset(started, episodes, /*render=*/true);
    for (int env : started) {
      Slot& s = *slots[static_cast<size_t>(env)];
      const sim::NavMesh& navmesh = envs_->simulator(env).scene().navmesh();
      s.oracle = std::make_unique<WaypointOracle>(
          navmesh, config_.sim.agent, config_.task.follower_goal_radius,
          s.episode->reference_path);
      s.goal = s.episode->goals.front().position;
      s.startDistance =
          s.episode->geodesic_distance
              ? *s.episode->geodesic_distance
              : navmesh.geodesicDistance(s.episode->start_position, s.goal);
      if (usePolicy)
        s.hidden = torch::zeros({model.numRecurrentLayers(), model.hidden_size},
                                device);
      if (usePolicy && exact)
        s.instruction = policy->encodeInstruction(
            eval::batchInstructions(std::span(&s.episode, 1),
                                    config_.dataset.max_instruction_length)
                .to(device));
    }
  };
  std::vector<int> all(static_cast<size_t>(numEnvs));
  for (int i = 0; i < numEnvs; ++i) all[static_cast<size_t>(i)] = i;
  assign(all);

  // the policy's instruction encoding of the active environments, redone
  // whenever the set of running episodes changes
  models::EncodedInstruction instruction;
  std::vector<const data::Episode*> encodedFor;

  while (true) {
    std::vector<int> active;
    for (int env = 0; env < numEnvs; ++env)
      if (slots[static_cast<size_t>(env)]) active.push_back(env);
    if (active.empty()) break;
    const auto n = static_cast<int64_t>(active.size());

    // encode this step's observations once for the store and the policy
    eval::ObservationBatch obs = eval::batchObservations(*envs_, active, model);
    const models::VisualFeatures features = encode(obs, device);
    frames += n;

    // oracle labels and progress targets at the current poses
    std::vector<sim::Action> oracle(static_cast<size_t>(n));
    std::vector<float> targets(static_cast<size_t>(n));
    envs_->forEach(active, [&](int env) {
      const auto k = static_cast<size_t>(
          std::find(active.begin(), active.end(), env) - active.begin());
      Slot& s = *slots[static_cast<size_t>(env)];
      const sim::AgentState& agent = envs_->state(env).agent;
      oracle[k] = s.oracle->next(agent);
      targets[k] = progressTarget(
          s.startDistance,
          envs_->simulator(env).scene().navmesh().geodesicDistance(
              agent.position, s.goal));
    });

    // the policy's argmax, with its recurrent state carried along
    std::vector<int64_t> policyActions;
    if (usePolicy && exact) {
      // one environment at a time: the same numbers whatever runs beside it
      for (int64_t k = 0; k < n; ++k) {
        Slot& s = *slots[static_cast<size_t>(active[static_cast<size_t>(k)])];
        models::PolicyInputs inputs;
        if (features.rgb.defined())
          inputs.rgb = features.rgb.slice(0, k, k + 1);
        if (features.depth.defined())
          inputs.depth = features.depth.slice(0, k, k + 1);
        inputs.prev_actions =
            torch::full({1}, s.prevAction, torch::kInt64).to(device);
        inputs.not_done =
            torch::full({1}, s.oracleActions.empty() ? 0.0f : 1.0f).to(device);
        models::PolicyOutputs out =
            policy->step(s.instruction, inputs, s.hidden.unsqueeze(0));
        policyActions.push_back(out.logits.argmax(-1).item<int64_t>());
        s.hidden = out.hidden[0];
      }
    } else if (usePolicy) {
      std::vector<const data::Episode*> episodes;
      for (int env : active)
        episodes.push_back(slots[static_cast<size_t>(env)]->episode);
      if (episodes != encodedFor) {
        instruction = policy->encodeInstruction(
            eval::batchInstructions(episodes,
                                    config_.dataset.max_instruction_length)
                .to(device));
        encodedFor = episodes;
      }
      std::vector<torch::Tensor> hidden;
      std::vector<int64_t> prev;
      std::vector<float> notDone;
      for (int env : active) {
        Slot& s = *slots[static_cast<size_t>(env)];
        hidden.push_back(s.hidden);
        prev.push_back(s.prevAction);
        notDone.push_back(s.oracleActions.empty() ? 0.0f : 1.0f);
      }
      models::PolicyInputs inputs;
      inputs.rgb = features.rgb;
      inputs.depth = features.depth;
      inputs.prev_actions = torch::tensor(prev, torch::kInt64).to(device);
      inputs.not_done = torch::tensor(notDone, torch::kFloat32).to(device);
      models::PolicyOutputs out =
          policy->step(instruction, inputs, torch::stack(hidden));
      const torch::Tensor argmax = out.logits.argmax(-1).to(torch::kCPU);
      policyActions.assign(argmax.data_ptr<int64_t>(),
                           argmax.data_ptr<int64_t>() + n);
      for (int64_t k = 0; k < n; ++k)
        slots[static_cast<size_t>(active[static_cast<size_t>(k)])]->hidden =
            out.hidden[k];
    }

    // record the step and choose the action taken
    const torch::Tensor rgbCpu = features.rgb.defined()
                                     ? features.rgb.to(torch::kCPU, storeType)
                                     : torch::Tensor();
    const torch::Tensor depthCpu =
        features.depth.defined() ? features.depth.to(torch::kCPU, storeType)
                                 : torch::Tensor();
    std::vector<sim::Action> actions(static_cast<size_t>(n));
    for (int64_t k = 0; k < n; ++k) {
      Slot& s = *slots[static_cast<size_t>(active[static_cast<size_t>(k)])];
      if (rgbCpu.defined()) s.rgb.push_back(rgbCpu[k].clone());
      if (depthCpu.defined()) s.depth.push_back(depthCpu[k].clone());
      s.prevActions.push_back(static_cast<uint8_t>(s.prevAction));
      const sim::Action label = oracle[static_cast<size_t>(k)];
      s.oracleActions.push_back(static_cast<uint8_t>(label));
      s.progress.push_back(targets[static_cast<size_t>(k)]);
      sim::Action taken = label;
      if (usePolicy) {
        const bool takeOracle = common::uniform01(s.coins) < round.beta;
        if (!takeOracle)
          taken = sim::actionFromInt(
              static_cast<int>(policyActions[static_cast<size_t>(k)]));
      }
      s.oracleSteps += taken == label;
      actions[static_cast<size_t>(k)] = taken;
      s.prevAction = static_cast<int64_t>(taken);
    }
    envs_->step(active, actions, /*render=*/true);

    // finished episodes go to the store; their environments take new slots
    std::vector<int> freed;
    for (int env : active) {
      const sim::EpisodeState& state = envs_->state(env);
      if (!state.done) continue;
      Slot& s = *slots[static_cast<size_t>(env)];
      StoredEpisode e;
      e.key.episode_id = s.episode->episode_id;
      e.key.iteration = round.iteration;
      e.key.slot = s.slot;
      e.key.source = s.source;
      const auto& tokens = s.episode->instruction.instruction_tokens;
      const int length = std::min(data::unpaddedLength(tokens),
                                  config_.dataset.max_instruction_length);
      e.tokens.assign(tokens.begin(), tokens.begin() + length);
      e.prev_actions = std::move(s.prevActions);
      e.oracle_actions = std::move(s.oracleActions);
      e.progress = std::move(s.progress);
      if (!s.rgb.empty()) e.rgb = torch::stack(s.rgb);
      if (!s.depth.empty()) e.depth = torch::stack(s.depth);
      store.append(e);
      ++stats.episodes;
      stats.steps += e.length();
      stats.oracle_steps += s.oracleSteps;
      stats.cut_at_limit += !state.called_stop;
      // the ground truth is the train split's; augmentation episodes may
      // reuse its episode ids
      if (!usePolicy && groundTruth && s.source == 0) {
        auto it = groundTruth->find(e.key.episode_id);
        if (it != groundTruth->end()) {
          const auto& gt = it->second.actions;
          ++stats.gt_episodes;
          bool identical = gt.size() == e.oracle_actions.size();
          const size_t common = std::min(gt.size(), e.oracle_actions.size());
          for (size_t t = 0; t < common; ++t) {
            const bool equal = static_cast<int>(gt[t]) == e.oracle_actions[t];
            stats.gt_equal_steps += equal;
            identical &= equal;
          }
          stats.gt_steps += static_cast<int64_t>(
              std::max(gt.size(), e.oracle_actions.size()));
          stats.gt_identical += identical;
          if (!identical)
            spdlog::debug(
                "oracle differs from ground truth on episode {} ({} vs {} "
                "actions)",
                e.key.episode_id, e.oracle_actions.size(), gt.size());
        }
      }
      slots[static_cast<size_t>(env)].reset();
      freed.push_back(env);
      ++stored;
      line.advance();
      if (progress) progress(stored, static_cast<int64_t>(pending.size()));
    }
    if (!freed.empty()) assign(freed);
  }
  stats.seconds = clock.seconds();
  spdlog::info(
      "collected {} episodes ({} steps) in {:.1f} s: {:.1f} episodes/min, "
      "{:.1f} frames/s, "
      "{:.1f}% oracle actions, {} cut at {} steps; store {} episodes, {:.0f} "
      "bytes/step",
      stats.episodes, stats.steps, stats.seconds,
      60.0 * static_cast<double>(stats.episodes) /
          std::max(stats.seconds, 1e-9),
      static_cast<double>(frames) / std::max(stats.seconds, 1e-9),
      100.0 * static_cast<double>(stats.oracle_steps) /
          std::max<double>(1.0, static_cast<double>(stats.steps)),
      stats.cut_at_limit, config_.task.max_episode_steps, store.size(),
      store.bytesPerStep());
  return stats;
}

}  // namespace vln::train
