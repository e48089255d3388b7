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
#include "models/Loss.h"
#include "models/Policy.h"
#include "models/StateDict.h"
#include "train/Checkpoint.h"
#include "train/MetricsLog.h"
#include "train/PretrainCommon.h"
#include "train/PretrainTasks.h"
#include "train/TrainingSchedule.h"

namespace vln::train {
namespace fs = std::filesystem;

namespace {

// stream labels of data::deriveSeed, so that no two uses share draws
constexpr uint64_t kTrainEpisodeStream = 1000;
constexpr uint64_t kCoinStream = 2000;
constexpr uint64_t kEpochStream = 3000;
constexpr uint64_t kEvalEpisodeStream = 4000;
constexpr uint64_t kEvalCoinStream = 5000;

}  // namespace

namespace {

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
      setAdamLearningRate(*l->optimizer,
                          roundLearningRate(p.lr, p.lr_schedule, epoch,
                                            p.epochs_per_iteration));
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
                   {{"iteration", iteration},
                    {"epoch", epoch},
                    {"lr", adamLearningRate(*depthLearner.optimizer)},
                    {"updates", batches},
                    {"seconds", seconds},
                    {"frames", frames},
                    {"loss", loss},
                    {"blind_loss", blindLoss},
                    {"skipped", depthLearner.nonFinite.total +
                                    blindLearner.nonFinite.total}},
                   {{"epoch/loss", loss}, {"epoch/blind_loss", blindLoss}},
                   updates);
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
