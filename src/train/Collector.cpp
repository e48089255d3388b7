#include "train/Collector.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>

#include "common/Check.h"
#include "common/Progress.h"
#include "common/Random.h"
#include "data/Vocabulary.h"
#include "rollout/EpisodeScheduler.h"
#include "rollout/ObservationBatch.h"
#include "rollout/PolicyStepper.h"
#include "train/Distributed.h"
#include "train/RunDirectory.h"

namespace vln::train {

// ---------------------------------------------------------------------------
// oracle and progress

std::vector<Vec3f> expertWaypoints(const data::Episode& episode,
                                   const std::string& expert) {
  return rollout::oracleWaypoints(
      episode, rollout::parseOracleMode(expert, "trainer.expert"));
}

float progressTarget(float startDistance, float distance, bool clip) {
  if (!std::isfinite(distance) || !std::isfinite(startDistance) ||
      startDistance <= 0.0f)
    return 0.0f;
  const float progress = (startDistance - distance) / startDistance;
  return clip ? std::clamp(progress, -1.0f, 1.0f) : progress;
}

int64_t sampleFromLogits(std::span<const float> logits, double u) {
  VLN_CHECK_ARG(!logits.empty(), "sampleFromLogits(): no logits");
  // softmax in double, shifted by the maximum so exp() cannot overflow
  const double top = *std::max_element(logits.begin(), logits.end());
  std::vector<double> weights(logits.size());
  double total = 0.0;
  for (size_t i = 0; i < logits.size(); ++i)
    total += weights[i] = std::exp(static_cast<double>(logits[i]) - top);
  double cumulative = 0.0;
  for (size_t i = 0; i + 1 < logits.size(); ++i) {
    cumulative += weights[i];
    if (u * total < cumulative) return static_cast<int64_t>(i);
  }
  return static_cast<int64_t>(logits.size()) - 1;
}

// ---------------------------------------------------------------------------
// collection

namespace {

// The coins of slot `slot` of a round: a generator of its own, so that
// which actions are the oracle's does not depend on the environments.
uint64_t coinSeed(const CollectionRound& round, int32_t slot) {
  return common::deriveSeed(
      common::deriveSeed(round.seed,
                         1000003u + static_cast<uint64_t>(round.iteration)),
      static_cast<uint64_t>(slot));
}

}  // namespace

/// One environment's episode in progress and what it has recorded.
struct Collector::Slot {
  Slot(const CollectionRound& round, int32_t index,
       const sim::NavMesh& navmesh, const ExperimentConfig& config)
      : slot(index),
        episode(round.episodes[static_cast<size_t>(index)]),
        source(round.sources[static_cast<size_t>(index)]),
        oracle(navmesh, config.sim.agent, config.task.follower_goal_radius,
               expertWaypoints(*episode, config.trainer.expert)),
        coins(coinSeed(round, index)),
        goal(episode->goals.front().position),
        startDistance(episode->geodesic_distance
                          ? *episode->geodesic_distance
                          : navmesh.geodesicDistance(episode->start_position,
                                                     goal)) {}

  // one step: row k of the features (store dtype), the action before it,
  // the oracle's label and the progress target
  void record(const torch::Tensor& rgbRows, const torch::Tensor& depthRows,
              int64_t k, sim::Action label, float target) {
    if (rgbRows.defined()) rgb.push_back(rgbRows[k].clone());
    if (depthRows.defined()) depth.push_back(depthRows[k].clone());
    prevActions.push_back(static_cast<uint8_t>(prevAction));
    oracleActions.push_back(static_cast<uint8_t>(label));
    progress.push_back(target);
  }

  // the finished episode as the store keeps it
  StoredEpisode stored(int32_t iteration, int maxInstructionLength) {
    StoredEpisode e;
    e.key.episode_id = episode->episode_id;
    e.key.iteration = iteration;
    e.key.slot = slot;
    e.key.source = source;
    const auto& tokens = episode->instruction.instruction_tokens;
    const int length =
        std::min(data::unpaddedLength(tokens), maxInstructionLength);
    e.tokens.assign(tokens.begin(), tokens.begin() + length);
    e.prev_actions = std::move(prevActions);
    e.oracle_actions = std::move(oracleActions);
    e.progress = std::move(progress);
    if (!rgb.empty()) e.rgb = torch::stack(rgb);
    if (!depth.empty()) e.depth = torch::stack(depth);
    return e;
  }

  int32_t slot;
  const data::Episode* episode;
  uint8_t source;  ///< 0 train split, 1 aug split
  WaypointOracle oracle;
  std::mt19937_64 coins;
  Vec3f goal;
  float startDistance;
  std::vector<torch::Tensor> rgb, depth;  ///< per step [C, h, w]
  std::vector<uint8_t> prevActions, oracleActions;
  std::vector<float> progress;
  int64_t prevAction = 0;  ///< the action taken at the last step
  int64_t oracleSteps = 0;  ///< steps that took the oracle's action
};

namespace {

// Teacher forcing: how the oracle's actions of `e` (a train-split episode)
// compare with the split's ground truth (augmentation episodes may reuse
// its ids, hence train episodes only).
void compareWithGroundTruth(const data::GroundTruth& groundTruth,
                            const StoredEpisode& e, CollectionStats& stats) {
  auto it = groundTruth.find(e.key.episode_id);
  if (it == groundTruth.end()) return;
  const auto& gt = it->second.actions;
  ++stats.gt_episodes;
  bool identical = gt.size() == e.oracle_actions.size();
  const size_t common = std::min(gt.size(), e.oracle_actions.size());
  for (size_t t = 0; t < common; ++t) {
    const bool equal = static_cast<int>(gt[t]) == e.oracle_actions[t];
    stats.gt_equal_steps += equal;
    identical &= equal;
  }
  stats.gt_steps +=
      static_cast<int64_t>(std::max(gt.size(), e.oracle_actions.size()));
  stats.gt_identical += identical;
  if (!identical)
    spdlog::debug(
        "oracle differs from ground truth on episode {} ({} vs {} actions)",
        e.key.episode_id, e.oracle_actions.size(), gt.size());
}

}  // namespace

/// The collection of one round's pending slots on the episode scheduler.
class Collector::Job : public rollout::EpisodeJob {
 public:
  Job(Collector& collector, const CollectionRound& round,
      std::vector<int32_t> pending, FeatureStore& store,
      const std::shared_ptr<models::PolicyImpl>& policy,
      const data::GroundTruth* groundTruth,
      const std::function<void(int64_t, int64_t)>& progress,
      CollectionStats& stats)
      : c_(collector), config_(collector.config_), round_(round),
        pending_(std::move(pending)), store_(store),
        groundTruth_(policy == nullptr ? groundTruth : nullptr),
        progress_(progress), stats_(stats),
        storeType_(store.layout().fp16 ? torch::kHalf : torch::kFloat32),
        slots_(static_cast<size_t>(collector.envs_->size())),
        line_(strCat("collect round ", round.iteration, " (beta ", round.beta,
                     ")"),
              static_cast<int64_t>(pending_.size()), "episodes") {
    // the policy's state follows every trajectory (it runs at every step)
    if (policy != nullptr)
      stepper_ = std::make_unique<rollout::PolicyStepper>(
          policy, collector.envs_->size(),
          config_.dataset.max_instruction_length,
          config_.trainer.exact_resume ? rollout::InstructionBatching::kOneByOne
                                       : rollout::InstructionBatching::kJoint);
    if (stepper_ && collector.featureSource_)
      stepper_->setInstructionFeatures(collector.featureSource_);
  }

  rollout::EpisodeStart startOf(int index) override {
    const data::Episode& episode = *round_.episodes[static_cast<size_t>(
        pending_[static_cast<size_t>(index)])];
    VLN_CHECK_ARG(
        !episode.reference_path.empty() && !episode.goals.empty(), "Collector: "
        "episode ", episode.episode_id, " has no reference_path or goals (a "
        "test split cannot be collected)");
    return rollout::EpisodeStart::of(episode);
  }

  void started(const rollout::EnvBatch& batch) override {
    for (size_t k = 0; k < batch.size(); ++k) {
      const int env = batch.envs[k];
      auto& s = slots_[static_cast<size_t>(env)];
      s = std::make_unique<Slot>(
          round_, pending_[static_cast<size_t>(batch.episodes[k])],
          c_.envs_->simulator(env).scene().navmesh(), config_);
      if (stepper_) stepper_->start(env, *s->episode);
    }
  }

  // encodes the observations once for the store and the policy, labels
  // them with the oracle, records them and picks the actions taken
  std::vector<sim::Action> act(const rollout::EnvBatch& running) override {
    const std::vector<int>& active = running.envs;
    const models::VisualFeatures features = c_.encode(
        rollout::batchObservations(*c_.envs_, active, config_.model));
    frames += static_cast<int64_t>(active.size());

    // oracle labels and progress targets at the current poses
    std::vector<sim::Action> oracle(active.size());
    std::vector<float> targets(active.size());
    c_.envs_->forEach(active, [&](int env) {
      const size_t k = running.indexOf(env);
      Slot& s = *slots_[static_cast<size_t>(env)];
      const sim::AgentState& agent = c_.envs_->state(env).agent;
      oracle[k] = s.oracle.next(agent);
      targets[k] = progressTarget(
          s.startDistance,
          c_.envs_->simulator(env).scene().navmesh().geodesicDistance(
              agent.position, s.goal),
          config_.trainer.clip_progress_target);
    });

    // the policy's logits, with its recurrent state carried along
    torch::Tensor logits;
    if (stepper_)
      logits = stepper_->step(active, features)
                   .to(torch::kCPU, torch::kFloat)
                   .contiguous();

    // record the step and choose the action taken: the oracle's, or with
    // probability 1 - beta the policy's
    const auto store = [&](const torch::Tensor& t) {
      return t.defined() ? t.to(torch::kCPU, storeType_) : t;
    };
    const torch::Tensor rgb = store(features.rgb), depth = store(features.depth);
    std::vector<sim::Action> actions(active.size());
    for (size_t k = 0; k < active.size(); ++k) {
      Slot& s = *slots_[static_cast<size_t>(active[k])];
      s.record(rgb, depth, static_cast<int64_t>(k), oracle[k], targets[k]);
      sim::Action taken = oracle[k];
      if (stepper_ && common::uniform01(s.coins) >= round_.beta)
        taken = sim::actionFromInt(static_cast<int>(policyAction(logits, k, s)),
                                   config_.model.num_actions);
      s.oracleSteps += taken == oracle[k];
      actions[k] = taken;
      s.prevAction = static_cast<int64_t>(taken);
      if (stepper_) stepper_->took(active[k], s.prevAction);
    }
    return actions;
  }

  // the policy's action of row k: sampled with the slot's generator, or
  // the argmax (the first of equal maxima, as torch.argmax)
  int64_t policyAction(const torch::Tensor& logits, size_t k, Slot& s) const {
    const int64_t n = logits.size(-1);
    const std::span<const float> row(
        logits.data_ptr<float>() + static_cast<int64_t>(k) * n,
        static_cast<size_t>(n));
    if (config_.trainer.dagger_action == "sample")
      return sampleFromLogits(row, common::uniform01(s.coins));
    return std::max_element(row.begin(), row.end()) - row.begin();
  }

  // finished episodes go to the store, one transaction each
  void finished(const rollout::EnvBatch& ended) override {
    for (int env : ended.envs) {
      Slot& s = *slots_[static_cast<size_t>(env)];
      const StoredEpisode e = s.stored(round_.iteration,
                                       config_.dataset.max_instruction_length);
      store_.append(e);
      ++stats_.episodes;
      stats_.steps += e.length();
      stats_.oracle_steps += s.oracleSteps;
      stats_.cut_at_limit += !c_.envs_->state(env).called_stop;
      if (groundTruth_ && s.source == 0)
        compareWithGroundTruth(*groundTruth_, e, stats_);
      slots_[static_cast<size_t>(env)].reset();
      line_.advance();
      if (progress_)
        progress_(stats_.episodes, static_cast<int64_t>(pending_.size()));
    }
  }

  int64_t frames = 0;

 private:
  Collector& c_;
  const ExperimentConfig& config_;
  const CollectionRound& round_;
  std::vector<int32_t> pending_;
  FeatureStore& store_;
  const data::GroundTruth* groundTruth_;
  const std::function<void(int64_t, int64_t)>& progress_;
  CollectionStats& stats_;
  torch::Dtype storeType_;
  std::unique_ptr<rollout::PolicyStepper> stepper_;
  std::vector<std::unique_ptr<Slot>> slots_;  // per environment
  common::ProgressLine line_;
};

Collector::Collector(const ExperimentConfig& config,
                     std::shared_ptr<rollout::SceneCache> scenes,
                     models::ObservationEncoder encoder)
    : config_(config),
      scenes_(std::move(scenes)),
      encoder_(std::move(encoder)) {
  envs_ = std::make_unique<rollout::VectorEnv>(
      config_.trainer.num_envs, config_.sim, config_.task, scenes_,
      config_.trainer.env_threads);
}

Collector::~Collector() = default;

models::VisualFeatures Collector::encode(const rollout::ObservationBatch& obs) {
  const torch::Device device = models::modelDevice(config_.model);
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
    const std::shared_ptr<models::PolicyImpl>& policy,
    const data::GroundTruth* groundTruth,
    const std::function<void(int64_t, int64_t)>& progress) {
  VLN_CHECK_ARG(round.sources.size() == round.episodes.size(),
                "Collector::collect(): ", round.sources.size(), " sources for ",
                round.episodes.size(), " slots");
  const bool usePolicy = round.beta < 1.0;
  VLN_CHECK_ARG(!usePolicy || policy != nullptr,
                "Collector::collect(): beta = ", round.beta,
                " < 1 needs a policy");
  VLN_CHECK_ARG(round.num_shards >= 1 && round.shard >= 0 &&
                    round.shard < round.num_shards,
                "Collector::collect(): shard ", round.shard, " of ",
                round.num_shards, " does not exist");
  torch::NoGradGuard noGrad;
  encoder_->eval();
  if (policy) policy->eval();
  // VLN-CE's BatchNorm in train mode, for collection only: evaluation
  // shares this encoder
  struct BatchStatistics {
    models::ObservationEncoder& encoder;
    explicit BatchStatistics(models::ObservationEncoder& e, bool on)
        : encoder(e) {
      encoder->useRgbBatchStatistics(on);
    }
    ~BatchStatistics() { encoder->useRgbBatchStatistics(false); }
  } batchStatistics(encoder_, config_.model.rgb_batch_statistics);

  // the slots of this shard still missing from the store, in round order
  CollectionStats stats;
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

  common::Stopwatch clock;
  const int count = static_cast<int>(pending.size());
  Job job(*this, round, std::move(pending), store,
          usePolicy ? policy : std::shared_ptr<models::PolicyImpl>(),
          groundTruth, progress, stats);
  rollout::runEpisodes(*envs_, count, job, /*render=*/true);
  stats.seconds = clock.seconds();
  spdlog::info(
      "collected {} episodes ({} steps) in {:.1f} s: {:.1f} episodes/min, "
      "{:.1f} frames/s, "
      "{:.1f}% oracle actions, {} cut at {} steps; store {} episodes, {:.0f} "
      "bytes/step",
      stats.episodes, stats.steps, stats.seconds,
      60.0 * static_cast<double>(stats.episodes) /
          std::max(stats.seconds, 1e-9),
      static_cast<double>(job.frames) / std::max(stats.seconds, 1e-9),
      100.0 * static_cast<double>(stats.oracle_steps) /
          std::max<double>(1.0, static_cast<double>(stats.steps)),
      stats.cut_at_limit, config_.task.max_episode_steps, store.size(),
      store.bytesPerStep());
  return stats;
}

// ---------------------------------------------------------------------------
// the store and the records

CollectionStats CollectionStats::overRanks(
    const std::function<std::vector<double>(const std::vector<double>&)>& sum,
    const std::function<int64_t(int64_t)>& max) const {
  CollectionStats all = *this;
  int64_t* fields[] = {&all.episodes,     &all.skipped,      &all.steps,
                       &all.oracle_steps, &all.cut_at_limit, &all.gt_episodes,
                       &all.gt_identical, &all.gt_steps,     &all.gt_equal_steps};
  std::vector<double> values;
  for (const int64_t* field : fields) values.push_back(static_cast<double>(*field));
  values = sum(values);
  for (size_t i = 0; i < std::size(fields); ++i)
    *fields[i] = static_cast<int64_t>(values[i]);
  all.seconds =
      static_cast<double>(max(static_cast<int64_t>(seconds * 1000.0))) / 1000.0;
  return all;
}

std::string storeConfigHash(const ExperimentConfig& config) {
  static const std::vector<std::string> prefixes = {
      "sim.",
      "task.",
      "dataset.data_path",
      "dataset.train_split",
      "dataset.aug_split",
      "dataset.max_train_episodes",
      "dataset.max_aug_episodes",
      "dataset.max_instruction_length",
      "model.rgb_encoder",
      "model.depth_encoder",
      "model.rgb_weights",
      "model.depth_weights",
      "model.no_rgb",
      "model.no_depth",
      "model.rgb_height",
      "model.rgb_width",
      "model.depth_height",
      "model.depth_width",
      "model.depth_resnet_base_planes",
      "model.rgb_batch_statistics",
      "trainer.seed",
      "trainer.use_aug",
      "trainer.dagger_episodes",
      "trainer.dagger_beta",
      "trainer.fine_tune_dagger",
      "trainer.expert",
      "trainer.dagger_action",
      "trainer.clip_progress_target",
      "trainer.store_fp16"};
  // env_threads and num_envs are left out on purpose: collection does not
  // depend on them (per-slot coins)
  std::string text;
  for (const auto& [key, value] : flattenConfig(config)) {
    if (key == "sim.scenes_dir")
      continue;  // where scenes live, not what they are
    // model.normalize_rgb changes the stored RGB features; it enters the
    // hash only when off, so that stores written before the key existed
    // (all normalised with ImageNet statistics) keep their hash
    if (key == "model.normalize_rgb") {
      if (!config.model.normalize_rgb) text += key + "=" + value + "\n";
      continue;
    }
    // keys added after stores existed enter only away from their defaults,
    // for the same reason: the look actions (RxR) and more training splits
    if (key == "sim.agent.look_actions" || key == "sim.agent.tilt_angle") {
      if (config.sim.agent.look_actions) text += key + "=" + value + "\n";
      continue;
    }
    // RxR runs read other files (and their filter picks the episodes);
    // the text features are read at batch time, not stored
    if (key.rfind("dataset.format", 0) == 0 ||
        key.rfind("dataset.rxr_filter.", 0) == 0) {
      if (config.dataset.isRxr()) text += key + "=" + value + "\n";
      continue;
    }
    if (key == "dataset.extra_train_splits") {
      if (!config.dataset.extra_train_splits.empty())
        text += key + "=" + value + "\n";
      continue;
    }
    for (const auto& prefix : prefixes)
      if (key.rfind(prefix, 0) == 0) {
        text += key + "=" + value + "\n";
        break;
      }
  }
  return common::fnv1aHex(text);
}

std::unique_ptr<FeatureStore> openFeatureStore(const ExperimentConfig& config,
                                               const std::filesystem::path& dir) {
  StoreLayout layout;
  if (config.model.usesRgb())
    layout.rgb_shape = models::rgbFeatureShape(config.model);
  if (config.model.usesDepth())
    layout.depth_shape = models::depthFeatureShape(config.model);
  layout.fp16 = config.trainer.store_fp16;
  layout.config_hash = storeConfigHash(config);
  auto store = std::make_unique<FeatureStore>(dir, layout,
                                              config.trainer.store_max_gib);
  spdlog::info(
      "feature store {}: {} episodes, {} steps, {:.0f} bytes/step ({} feature "
      "bytes per step, {})",
      store->dir().string(), store->size(), store->totalSteps(),
      store->bytesPerStep(), layout.featureBytesPerStep(),
      layout.fp16 ? "float16" : "float32");
  return store;
}

StoreTotals totalsOverRanks(const FeatureStore& store, Distributed* dist) {
  StoreTotals totals{store.size(), store.bytesPerStep()};
  if (!dist) return totals;
  const std::vector<double> sums =
      dist->allReduceSum({static_cast<double>(store.size()),
                          static_cast<double>(store.totalBytes()),
                          static_cast<double>(store.totalSteps())});
  totals.episodes = static_cast<int64_t>(sums[0]);
  totals.bytes_per_step = sums[2] > 0.0 ? sums[1] / sums[2] : 0.0;
  return totals;
}

void logCollection(const CollectionStats& stats, const CollectionRound& round,
                   const StoreTotals& totals, const std::string& trainSplit,
                   bool expertFollowsGroundTruth, MetricsLog* metrics) {
  const int iteration = round.iteration;
  nlohmann::json record = {{"iteration", iteration},
                           {"beta", round.beta},
                           {"episodes", stats.episodes},
                           {"skipped", stats.skipped},
                           {"steps", stats.steps},
                           {"seconds", stats.seconds},
                           {"oracle_steps", stats.oracle_steps},
                           {"cut_at_limit", stats.cut_at_limit},
                           {"store_episodes", totals.episodes},
                           {"store_bytes_per_step", totals.bytes_per_step}};
  std::vector<std::pair<std::string, double>> scalars = {
      {"collect/beta", round.beta},
      {"collect/store_episodes", static_cast<double>(totals.episodes)},
      {"collect/bytes_per_step", totals.bytes_per_step}};
  if (stats.seconds > 0 && stats.episodes > 0) {
    record["episodes_per_minute"] =
        60.0 * static_cast<double>(stats.episodes) / stats.seconds;
    record["frames_per_second"] =
        static_cast<double>(stats.steps) / stats.seconds;
    scalars.emplace_back("collect/frames_per_second",
                         static_cast<double>(stats.steps) / stats.seconds);
  }
  if (stats.gt_episodes > 0) {
    const double identical = static_cast<double>(stats.gt_identical) /
                             static_cast<double>(stats.gt_episodes);
    const double steps =
        static_cast<double>(stats.gt_equal_steps) /
        static_cast<double>(std::max<int64_t>(1, stats.gt_steps));
    record["gt_episodes"] = stats.gt_episodes;
    record["gt_identical_rate"] = identical;
    record["gt_step_agreement"] = steps;
    scalars.emplace_back("collect/gt_identical_rate", identical);
    // the goal expert takes shortcuts the ground truth does not
    auto level = identical < 1.0 && expertFollowsGroundTruth
                     ? spdlog::level::warn
                     : spdlog::level::info;
    spdlog::log(level,
                "oracle vs ground truth ({}): {}/{} episodes identical "
                "({:.1f}%), {:.1f}% of "
                "steps agree",
                trainSplit, stats.gt_identical, stats.gt_episodes,
                100.0 * identical, 100.0 * steps);
  }
  if (metrics) metrics->write("collect", record, scalars, iteration);
}

}  // namespace vln::train
