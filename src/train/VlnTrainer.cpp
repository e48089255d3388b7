#include "train/VlnTrainer.h"

#include <ATen/CPUGeneratorImpl.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <optional>
#include <random>

#include "common/Check.h"
#include "common/FileIo.h"
#include "common/Json.h"
#include "common/Progress.h"
#include "common/Random.h"
#include "data/Episode.h"
#include "data/Glove.h"
#include "data/GroundTruth.h"
#include "eval/Evaluator.h"
#include "eval/PolicyAgent.h"
#include "models/Export.h"
#include "models/ObservationEncoder.h"
#include "models/Policy.h"
#include "models/StateDict.h"
#include "train/Collector.h"
#include "train/Distributed.h"
#include "train/DistributedTraining.h"
#include "train/FeatureStore.h"
#include "train/ImitationLearner.h"
#include "train/MetricsLog.h"
#include "train/RunDirectory.h"

namespace vln::train {
namespace fs = std::filesystem;

namespace {

constexpr const char* kTeacherForcing = "teacher_forcing";
constexpr const char* kDagger = "dagger";

// a split's episodes (capped) and its ground truth when the file exists
struct Split {
  std::string name;
  data::EpisodeDataset dataset;
  std::unique_ptr<data::GroundTruth> groundTruth;
};

Split loadSplit(const fs::path& root, const std::string& name, int cap) {
  Split split;
  split.name = name;
  split.dataset = data::readEpisodes(data::splitEpisodesPath(root, name));
  data::keepEvenlySpaced(split.dataset.episodes, cap);
  const fs::path gt = data::splitGroundTruthPath(root, name);
  if (fs::exists(gt))
    split.groundTruth =
        std::make_unique<data::GroundTruth>(data::readGroundTruth(gt));
  return split;
}

// policy tensors from one of our checkpoints, from a run directory (its
// best checkpoint by selection SPL, else its latest: how a DA* config names
// the run it fine-tunes) or from a TorchScript tensor file
// (models/StateDict.h)
models::NamedTensors readPolicyWeights(const fs::path& given) {
  fs::path file = given;
  if (fs::is_directory(given)) {
    file = bestOrLatestCheckpoint(given);
    spdlog::info("trainer.init_checkpoint: run directory {} -> {}", given.string(),
                 file.string());
  }
  try {
    return loadCheckpoint(file).policy;
  } catch (const std::runtime_error& checkpointError) {
    try {
      return models::readTensorFile(file);
    } catch (const std::runtime_error&) {
      throw std::runtime_error("trainer.init_checkpoint: '" + file.string() +
                               "' is neither a checkpoint nor a tensor file: " +
                               checkpointError.what());
    }
  }
}

torch::Tensor embeddingTensor(const ExperimentConfig& config) {
  const fs::path file = config.dataset.embeddingsPath();
  data::EmbeddingMatrix matrix = data::readEmbeddingsJson(file);
  VLN_CHECK_ARG(matrix.rows == config.model.vocab_size &&
                    matrix.dim == config.model.embedding_dim,
                "train: the embeddings '", file.string(), "' are ", matrix.rows,
                " x ", matrix.dim,
                " but model.vocab_size x model.embedding_dim is ",
                config.model.vocab_size, " x ", config.model.embedding_dim,
                " (set the model to the vocabulary of dataset.data_path)");
  return torch::from_blob(matrix.values.data(), {matrix.rows, matrix.dim},
                          torch::kFloat32)
      .clone();
}

std::string rngState() {
  auto generator = at::detail::getDefaultCPUGenerator();
  std::lock_guard<std::mutex> lock(generator.mutex());
  const torch::Tensor state = generator.get_state().contiguous();
  return std::string(static_cast<const char*>(state.data_ptr()),
                     static_cast<size_t>(state.numel()));
}

void restoreRngState(const std::string& bytes, const std::string& source) {
  if (bytes.empty()) return;
  auto generator = at::detail::getDefaultCPUGenerator();
  std::lock_guard<std::mutex> lock(generator.mutex());
  torch::Tensor state =
      torch::empty({static_cast<int64_t>(bytes.size())}, torch::kUInt8);
  std::memcpy(state.data_ptr(), bytes.data(), bytes.size());
  try {
    generator.set_state(state);
  } catch (const c10::Error& error) {
    throw std::runtime_error(
        "train --resume: '" + source +
        "' holds an invalid RNG state: " + error.what_without_backtrace());
  }
}

nlohmann::json metricsJson(const eval::EpisodeMetrics& m) {
  return {{"distance_to_goal", m.distance_to_goal},
          {"success", m.success},
          {"spl", m.spl},
          {"ndtw", m.ndtw},
          {"sdtw", m.sdtw},
          {"path_length", m.path_length},
          {"oracle_success", m.oracle_success},
          {"steps_taken", m.steps_taken}};
}

}  // namespace

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
      "trainer.seed",
      "trainer.use_aug",
      "trainer.dagger_episodes",
      "trainer.dagger_beta",
      "trainer.fine_tune_dagger",
      "trainer.store_fp16"};
  // env_threads and num_envs are left out on purpose: collection does not
  // depend on them (per-slot coins)
  std::string text;
  for (const auto& [key, value] : flattenConfig(config)) {
    if (key == "sim.scenes_dir")
      continue;  // where scenes live, not what they are
    for (const auto& prefix : prefixes)
      if (key.rfind(prefix, 0) == 0) {
        text += key + "=" + value + "\n";
        break;
      }
  }
  return common::fnv1aHex(text);
}

fs::path bestOrLatestCheckpoint(const fs::path& runDir) {
  const fs::path dir = runDir / "checkpoints";
  const fs::path best = dir / "best.json";
  if (fs::exists(best)) {
    const auto json = common::readJsonFile(best);
    const fs::path file = dir / common::requireField<std::string>(
                                    json, "checkpoint", best.string());
    VLN_CHECK_IO(fs::exists(file), "train: ", best.string(), " names '",
                 file.string(), "', which does not exist");
    return file;
  }
  const auto all = listCheckpoints(dir);
  VLN_CHECK_IO(!all.empty(), "train: '", dir.string(), "' holds no checkpoint");
  return all.back();
}

void exportCheckpoint(const fs::path& checkpoint,
                      const ExperimentConfig& config, const fs::path& out) {
  const Checkpoint ckpt = loadCheckpoint(checkpoint);
  auto policy = models::makePolicy(config.model);
  models::loadStateStrict(*policy, ckpt.policy, checkpoint.string());
  models::ObservationEncoder encoder(config.model);
  encoder->loadPretrained();
  models::exportPolicy(*policy, encoder.get(), out);
  spdlog::info("exported {} to {}", checkpoint.string(), out.string());
}

// ---------------------------------------------------------------------------
// the trainer

struct VlnTrainer::Impl {
  ExperimentConfig config;
  fs::path runDir, checkpointDir, evalDir;
  torch::Device device{torch::kCPU};

  Split train;
  std::unique_ptr<Split> aug;
  std::vector<Split> evalSplits;

  std::shared_ptr<models::PolicyImpl> policy;
  models::ObservationEncoder encoder{nullptr};
  std::unique_ptr<ImitationLearner> learner;
  std::unique_ptr<FeatureStore> store;
  std::shared_ptr<eval::SceneCache> scenes;
  std::unique_ptr<Collector> collector;
  std::unique_ptr<MetricsLog> metrics;

  TrainingProgress progress;
  bool haveCheckpoint = false;
  int evalsSinceBest = 0;
  int64_t epochsDone = 0;

  // multi-process: this rank's group (nullptr: one process), and the
  // episodes and bytes per step of all ranks' stores together (updated
  // when a round is collected)
  Distributed* dist = nullptr;
  int64_t storeEpisodes = 0;
  double storeBytesPerStep = 0.0;

  bool dagger() const { return config.trainer.dagger_iterations > 0; }
  // rank 0 (or the only process) writes the run's files
  bool master() const { return !dist || dist->isMaster(); }

  void writeMetrics(const std::string& type, nlohmann::json record,
                    const std::vector<std::pair<std::string, double>>& scalars,
                    int64_t step) {
    if (metrics) metrics->write(type, std::move(record), scalars, step);
  }

  // store totals over the ranks (a collective in a multi-process run)
  void updateStoreTotals() {
    storeEpisodes = store->size();
    storeBytesPerStep = store->bytesPerStep();
    if (!dist) return;
    const std::vector<double> sums =
        dist->allReduceSum({static_cast<double>(store->size()),
                            static_cast<double>(store->totalBytes()),
                            static_cast<double>(store->totalSteps())});
    storeEpisodes = static_cast<int64_t>(sums[0]);
    storeBytesPerStep = sums[2] > 0.0 ? sums[1] / sums[2] : 0.0;
  }

  // the ranks' policies must be bitwise identical (same updates applied)
  void checkRanksAgree(const std::string& when) {
    if (!dist) return;
    std::vector<torch::Tensor> tensors;
    std::vector<std::string> names;
    for (const auto& [name, tensor] : models::namedState(*policy)) {
      names.push_back(name);
      tensors.push_back(tensor);
    }
    dist->checkIdentical(tensors, names, when);
  }

  // the fewest episodes of any collection round (every rank needs one)
  size_t smallestRound() const {
    const size_t pooled = pool(nullptr).size();
    if (!dagger()) return pooled;
    size_t smallest = static_cast<size_t>(config.trainer.dagger_episodes);
    for (int n = 0; n < config.trainer.dagger_iterations; ++n)
      if (betaOf(n) >= 1.0) smallest = std::min(smallest, pooled);
    return smallest;
  }

  // --- setup ---------------------------------------------------------------

  void setup(bool resume) {
    runDir = config.output.dir;
    checkpointDir = runDir / "checkpoints";
    evalDir = runDir / "eval";
    device = models::modelDevice(config.model);
    torch::manual_seed(static_cast<uint64_t>(config.trainer.seed));

    // data
    const fs::path root = config.dataset.data_path;
    train = loadSplit(root, config.dataset.train_split,
                      config.dataset.max_train_episodes);
    VLN_CHECK_ARG(!train.dataset.episodes.empty(),
                  "train: dataset.train_split '", config.dataset.train_split,
                  "' under '", root.string(), "' has no episodes");
    spdlog::info("training split '{}': {} episodes{}", train.name,
                 train.dataset.episodes.size(),
                 train.groundTruth ? "" : " (no ground-truth file)");
    if (config.trainer.use_aug) {
      aug = std::make_unique<Split>(loadSplit(root, config.dataset.aug_split,
                                              config.dataset.max_aug_episodes));
      spdlog::info("augmentation split '{}': {} episodes", aug->name,
                   aug->dataset.episodes.size());
    }
    if (config.trainer.eval_during_training)
      for (const auto& name : config.eval.splits) {
        const int cap = config.eval.train_eval_episodes >= 0
                            ? config.eval.train_eval_episodes
                            : config.eval.episodes;
        evalSplits.push_back(loadSplit(root, name, cap));
      }

    // models
    torch::Tensor embeddings;
    if (config.model.usesInstruction()) embeddings = embeddingTensor(config);
    policy = models::makePolicy(config.model, embeddings);
    encoder = models::ObservationEncoder(config.model);
    encoder->loadPretrained();
    encoder->to(device);
    encoder->eval();
    int64_t parameters = 0, trainable = 0;
    for (const auto& p : policy->parameters()) {
      parameters += p.numel();
      if (p.requires_grad()) trainable += p.numel();
    }
    spdlog::info("policy {}: {} parameters, {} trainable",
                 models::policyName(config.model.policy), parameters,
                 trainable);

    if (dist) {
      const size_t smallest = smallestRound();
      VLN_CHECK_ARG(
          smallest >= static_cast<size_t>(dist->worldSize()),
          "train: WORLD_SIZE = ", dist->worldSize(), " is larger than the ",
          smallest, " episodes of a collection round (",
          dagger() ? "trainer.dagger_episodes or the training pool"
                   : "the training pool: dataset.train_split",
          config.trainer.use_aug ? " + dataset.aug_split" : "",
          ", capped by dataset.max_train_episodes): every rank needs at "
          "least one episode");
    }

    // the checkpoint to resume from; in a multi-process run rank 0 reads it
    // and sends it to the others (whose run directory may be elsewhere)
    std::optional<Checkpoint> resumeFrom;
    std::string resumeSource;
    if (master()) {
      const auto checkpoints = listCheckpoints(checkpointDir);
      if (resume && !checkpoints.empty()) {
        resumeSource = checkpoints.back().string();
        resumeFrom = loadCheckpoint(checkpoints.back());
      }
    }
    if (dist) {
      const std::string bytes = dist->broadcastBytes(
          resumeFrom ? serializeCheckpoint(*resumeFrom) : std::string());
      if (!master() && !bytes.empty()) {
        resumeSource = "rank 0's checkpoint";
        resumeFrom = deserializeCheckpoint(bytes, resumeSource);
      }
    }
    haveCheckpoint = resumeFrom.has_value();
    // rank 0 reads init_checkpoint; the others receive its weights below
    if (!haveCheckpoint && !config.trainer.init_checkpoint.empty() &&
        master()) {
      models::loadStateStrict(*policy,
                              readPolicyWeights(config.trainer.init_checkpoint),
                              config.trainer.init_checkpoint);
      spdlog::info("initialised the policy from {}",
                   config.trainer.init_checkpoint);
    }
    learner = std::make_unique<ImitationLearner>(policy, config);
    if (dist) learner->setDistributed(dist);
    if (config.trainer.inflection_weight <= 0.0) {
      std::vector<const data::GroundTruth*> gts = {train.groundTruth.get()};
      if (aug) gts.push_back(aug->groundTruth.get());
      learner->setInflectionCoef(inverseInflectionFrequency(gts));
      spdlog::info(
          "inflection weight: {:.4f} (inverse inflection frequency of the "
          "ground truth)",
          learner->inflectionCoef());
    }

    if (haveCheckpoint) {
      const Checkpoint& ckpt = *resumeFrom;
      const std::string& last = resumeSource;
      models::loadStateStrict(*policy, ckpt.policy, last);
      loadOptimizerState(learner->optimizer(), ckpt.optimizer_state, last);
      restoreRngState(ckpt.rng_state, last);
      progress = ckpt.progress;
      learner->setUpdates(progress.updates);
      evalsSinceBest = progress.extra.value("evals_since_best", 0);
      epochsDone = progress.extra.value("epochs_done", int64_t{0});
      spdlog::info(
          "resuming from {}: stage {}, {} DAgger iterations and {} epochs "
          "done, {} updates",
          last, progress.stage, progress.dagger_iteration, progress.epoch,
          progress.updates);
    } else {
      progress = TrainingProgress{};
      progress.checkpoint_index = -1;
      progress.stage = dagger() ? kDagger : kTeacherForcing;
    }

    // the store
    StoreLayout layout;
    if (config.model.usesRgb())
      layout.rgb_shape = models::rgbFeatureShape(config.model);
    if (config.model.usesDepth())
      layout.depth_shape = models::depthFeatureShape(config.model);
    layout.fp16 = config.trainer.store_fp16;
    layout.config_hash = storeConfigHash(config);
    store = std::make_unique<FeatureStore>(
        dist ? storeShardDir(runDir, dist->rank()) : runDir / "store", layout,
        config.trainer.store_max_gib);
    spdlog::info(
        "feature store {}: {} episodes, {} steps, {:.0f} bytes/step ({} "
        "feature bytes "
        "per step, {})",
        store->dir().string(), store->size(), store->totalSteps(),
        store->bytesPerStep(), layout.featureBytesPerStep(),
        layout.fp16 ? "float16" : "float32");

    updateStoreTotals();

    scenes = std::make_shared<eval::SceneCache>(config.sim);
    if (master())
      metrics = std::make_unique<MetricsLog>(
          runDir / "metrics.jsonl",
          config.output.tensorboard ? runDir / "tb" : fs::path());

    if (dist) {
      // every rank starts from rank 0's weights and Adam state
      dist->broadcastModule(*policy);
      dist->broadcastOptimizer(learner->optimizer());
      checkRanksAgree("at the start");
      spdlog::info("distributed: rank {} of {} ({}), store shard {}",
                   dist->rank(), dist->worldSize(), dist->backendName(),
                   store->dir().string());
    }
  }

  // --- collection ------------------------------------------------------------

  std::vector<const data::Episode*> pool(std::vector<uint8_t>* sources) const {
    std::vector<const data::Episode*> episodes;
    for (const auto& e : train.dataset.episodes) {
      episodes.push_back(&e);
      if (sources) sources->push_back(0);
    }
    if (aug)
      for (const auto& e : aug->dataset.episodes) {
        episodes.push_back(&e);
        if (sources) sources->push_back(1);
      }
    return episodes;
  }

  double betaOf(int iteration) const {
    if (!dagger()) return 1.0;
    const double p = config.trainer.dagger_beta;
    if (p == 0.0) return 0.0;  // VLN-CE: 0^0 would be 1
    return std::pow(p, iteration + (config.trainer.fine_tune_dagger ? 1 : 0));
  }

  CollectionRound roundOf(int iteration) const {
    CollectionRound round;
    round.iteration = iteration;
    round.beta = betaOf(iteration);
    round.seed = static_cast<uint64_t>(config.trainer.seed);
    std::vector<uint8_t> sources;
    std::vector<const data::Episode*> episodes = pool(&sources);
    if (!dagger()) {
      round.episodes = std::move(episodes);
      round.sources = std::move(sources);
      return round;
    }
    std::vector<size_t> order(episodes.size());
    for (size_t i = 0; i < order.size(); ++i) order[i] = i;
    std::mt19937_64 rng(
        common::deriveSeed(round.seed, 7000u + static_cast<uint64_t>(iteration)));
    common::deterministicShuffle(order, rng);
    size_t count = static_cast<size_t>(config.trainer.dagger_episodes);
    if (round.beta >= 1.0) count = std::min(count, order.size());
    for (size_t k = 0; k < count; ++k) {
      const size_t i = order[k % order.size()];
      round.episodes.push_back(episodes[i]);
      round.sources.push_back(sources[i]);
    }
    return round;
  }

  void collect(int iteration) {
    CollectionRound round = roundOf(iteration);
    if (dist) {
      round.shard = dist->rank();
      round.num_shards = dist->worldSize();
    }
    if (!collector)
      collector = std::make_unique<Collector>(config, scenes, encoder);
    CollectionStats stats = collector->collect(
        round, *store, round.beta < 1.0 ? policy.get() : nullptr,
        round.beta >= 1.0 ? train.groundTruth.get() : nullptr);
    if (dist) {
      // every shard is complete before anyone trains; the record covers
      // the whole round (its wall time is the slowest rank's)
      dist->waitForAll(strCat("the end of collection round ", iteration));
      const std::vector<double> sums = dist->allReduceSum(
          {static_cast<double>(stats.episodes),
           static_cast<double>(stats.skipped), static_cast<double>(stats.steps),
           static_cast<double>(stats.oracle_steps),
           static_cast<double>(stats.cut_at_limit),
           static_cast<double>(stats.gt_episodes),
           static_cast<double>(stats.gt_identical),
           static_cast<double>(stats.gt_steps),
           static_cast<double>(stats.gt_equal_steps)});
      int64_t* fields[] = {
          &stats.episodes,     &stats.skipped,      &stats.steps,
          &stats.oracle_steps, &stats.cut_at_limit, &stats.gt_episodes,
          &stats.gt_identical, &stats.gt_steps,     &stats.gt_equal_steps};
      for (size_t i = 0; i < std::size(fields); ++i)
        *fields[i] = static_cast<int64_t>(sums[i]);
      stats.seconds =
          static_cast<double>(
              dist->allReduceMax({static_cast<int64_t>(stats.seconds * 1000.0)})
                  .front()) /
          1000.0;
    }
    updateStoreTotals();
    if (!master()) return;
    nlohmann::json record = {{"iteration", iteration},
                             {"beta", round.beta},
                             {"episodes", stats.episodes},
                             {"skipped", stats.skipped},
                             {"steps", stats.steps},
                             {"seconds", stats.seconds},
                             {"oracle_steps", stats.oracle_steps},
                             {"cut_at_limit", stats.cut_at_limit},
                             {"store_episodes", storeEpisodes},
                             {"store_bytes_per_step", storeBytesPerStep}};
    std::vector<std::pair<std::string, double>> scalars = {
        {"collect/beta", round.beta},
        {"collect/store_episodes", static_cast<double>(storeEpisodes)},
        {"collect/bytes_per_step", storeBytesPerStep}};
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
      auto level = identical < 1.0 ? spdlog::level::warn : spdlog::level::info;
      spdlog::log(level,
                  "oracle vs ground truth ({}): {}/{} episodes identical "
                  "({:.1f}%), {:.1f}% of "
                  "steps agree",
                  train.name, stats.gt_identical, stats.gt_episodes,
                  100.0 * identical, 100.0 * steps);
    }
    writeMetrics("collect", record, scalars, iteration);
  }

  // --- checkpoints and evaluation
  // ---------------------------------------------

  void saveCheckpointNow(bool evalDue) {
    progress.checkpoint_index += 1;
    progress.updates = learner->updates();
    progress.episodes_collected = storeEpisodes;
    progress.extra["evals_since_best"] = evalsSinceBest;
    progress.extra["epochs_done"] = epochsDone;
    progress.extra["eval_due"] = evalDue;
    progress.extra["inflection_coef"] = learner->inflectionCoef();
    if (dist) progress.extra["world_size"] = dist->worldSize();
    if (!master()) return;  // the progress above is kept on every rank
    Checkpoint ckpt;
    ckpt.config_yaml = experimentConfigYaml(config);
    ckpt.policy = models::namedState(*policy);
    ckpt.optimizer_state = serializeOptimizer(learner->optimizer());
    ckpt.progress = progress;
    ckpt.rng_state = rngState();
    const fs::path file =
        checkpointDir / checkpointFileName(progress.checkpoint_index);
    saveCheckpoint(file, ckpt);
    spdlog::info("saved {} ({} updates)", file.string(), progress.updates);
    prune();
  }

  void prune() {
    const int keep = config.output.keep_checkpoints;
    if (keep < 0) return;
    const auto all = listCheckpoints(checkpointDir);
    const size_t kept = static_cast<size_t>(
        std::max(keep, 1));  // the newest is needed to resume
    for (size_t i = 0; i + kept < all.size(); ++i) {
      if (checkpointIndex(all[i]) == progress.best_checkpoint) continue;
      std::error_code ec;
      fs::remove(all[i], ec);
      if (!ec)
        spdlog::info("removed {} (output.keep_checkpoints = {})",
                     all[i].string(), keep);
    }
  }

  bool evaluated(int index) const {
    for (const auto& split : evalSplits)
      if (!fs::exists(evalDir / eval::statsFileName(index, split.name)))
        return false;
    return true;
  }

  // evaluates the policy in memory as checkpoint `index`; returns true when
  // training should stop early
  bool evaluate(int index) {
    const eval::EvalConfig& ec = config.eval;
    double selectionSpl = -1.0;
    for (const Split& split : evalSplits) {
      // multi-process: rank r runs episodes r, r + N, ... of the split
      std::vector<data::Episode> shard;
      const std::vector<data::Episode>* episodes = &split.dataset.episodes;
      if (dist) {
        for (size_t i = static_cast<size_t>(dist->rank());
             i < split.dataset.episodes.size();
             i += static_cast<size_t>(dist->worldSize()))
          shard.push_back(split.dataset.episodes[i]);
        episodes = &shard;
      }
      eval::VectorEnv envs(ec.num_envs, config.sim, config.task, scenes,
                           ec.threads);
      // on the heap: PolicyAgent.h declares no destructor, so one instantiated
      // here would need its private EnvState
      std::unique_ptr<eval::Agent> agent(
          new eval::PolicyAgent(policy, encoder, ec.num_envs, ec.sample_actions,
                                static_cast<uint64_t>(ec.seed),
                                config.dataset.max_instruction_length));
      common::ProgressLine line("evaluate " + split.name,
                                static_cast<int64_t>(episodes->size()),
                                "episodes");
      common::Stopwatch clock;
      const eval::EvaluationResult result = eval::evaluateEpisodes(
          *agent, envs, *episodes, split.groundTruth.get(), ec,
          [&](int, int) { line.advance(); });
      const eval::SplitStats stats =
          dist ? combineShards(result, strCat("the evaluation of checkpoint ",
                                              index, " on ", split.name))
               : result.stats;
      if (master()) eval::writeStatsFile(evalDir, index, split.name, stats);
      const auto& m = stats.mean;
      spdlog::info(
          "ckpt {} {} ({} episodes, {:.1f} s): TL {:.2f} NE {:.2f} nDTW {:.3f} "
          "OS {:.3f} "
          "SR {:.3f} SPL {:.3f}",
          index, split.name, stats.num_episodes, clock.seconds(), m.path_length,
          m.distance_to_goal, m.ndtw, m.oracle_success, m.success, m.spl);
      nlohmann::json record = metricsJson(m);
      record["checkpoint"] = index;
      record["split"] = split.name;
      record["num_episodes"] = stats.num_episodes;
      std::vector<std::pair<std::string, double>> scalars;
      const nlohmann::json values = metricsJson(m);
      for (const auto& [key, value] : values.items())
        scalars.emplace_back("eval/" + split.name + "/" + key,
                             value.get<double>());
      writeMetrics("eval", record, scalars, index);
      if (split.name == ec.selection_split) selectionSpl = m.spl;
    }
    policy->train();
    return recordEvaluation(index, selectionSpl);
  }

  // the whole split's means from every rank's shard (after all finished):
  // the sums of the scored episodes' metrics over the ranks, divided by
  // their count (as eval::aggregate() does in one process, up to the order
  // of the additions)
  eval::SplitStats combineShards(const eval::EvaluationResult& mine,
                                 const std::string& what) {
    dist->waitForAll(what);
    using M = eval::EpisodeMetrics;
    static constexpr double M::*kFields[] = {&M::distance_to_goal,
                                             &M::success,
                                             &M::spl,
                                             &M::ndtw,
                                             &M::sdtw,
                                             &M::path_length,
                                             &M::oracle_success,
                                             &M::steps_taken};
    constexpr size_t kCount = std::size(kFields);
    std::vector<double> sums(kCount + 1, 0.0);
    for (size_t i = 0; i < mine.episodes.size(); ++i) {
      if (!mine.scored[i]) continue;
      for (size_t f = 0; f < kCount; ++f)
        sums[f] += mine.episodes[i].metrics.*kFields[f];
      sums[kCount] += 1.0;
    }
    sums = dist->allReduceSum(sums);
    eval::SplitStats all;
    all.num_episodes = static_cast<int>(sums[kCount]);
    if (all.num_episodes == 0) return all;
    for (size_t f = 0; f < kCount; ++f)
      all.mean.*kFields[f] = sums[f] / sums[kCount];
    return all;
  }

  // best checkpoint and patience bookkeeping after an evaluation (the same
  // on every rank; rank 0 writes best.json)
  bool recordEvaluation(int index, double spl) {
    if (spl > progress.best_spl) {
      progress.best_spl = spl;
      progress.best_checkpoint = index;
      evalsSinceBest = 0;
      if (master())
        common::writeJsonFile(checkpointDir / "best.json",
                              {{"checkpoint", checkpointFileName(index)},
                               {"index", index},
                               {"split", config.eval.selection_split},
                               {"spl", spl}},
                              2);
      spdlog::info("new best checkpoint {}: {} SPL {:.4f}", index,
                   config.eval.selection_split, spl);
    } else {
      ++evalsSinceBest;
    }
    const int patience = config.trainer.early_stopping_patience;
    if (patience > 0 && evalsSinceBest >= patience) {
      spdlog::info(
          "early stopping: {} evaluations without a better {} SPL than {:.4f} "
          "(ckpt {})",
          evalsSinceBest, config.eval.selection_split, progress.best_spl,
          progress.best_checkpoint);
      return true;
    }
    return false;
  }

  // an evaluation that was due after the last checkpoint but did not finish
  bool catchUpEvaluation() {
    if (!haveCheckpoint || !config.trainer.eval_during_training) return false;
    const int index = progress.checkpoint_index;
    if (!progress.extra.value("eval_due", false)) return false;
    // rank 0's eval/ directory decides (the only one with stats files)
    bool done = master() && evaluated(index);
    if (dist) done = dist->broadcastBytes(done ? "1" : "0") == "1";
    if (done) {
      // finished before the kill: fold its result in from the stats file
      double spl = -1.0;
      if (master())
        for (const auto& split : evalSplits)
          if (split.name == config.eval.selection_split)
            spl = eval::readStatsFile(evalDir /
                                      eval::statsFileName(index, split.name))
                      .mean.spl;
      if (dist) spl = dist->allReduceSum({master() ? spl : 0.0}).front();
      return recordEvaluation(index, spl);
    }
    spdlog::info(
        "evaluating checkpoint {} (its evaluation did not finish before the "
        "interruption)",
        index);
    return evaluate(index);
  }

  // --- training
  // ---------------------------------------------------------------

  // epoch `epoch` of DAgger iteration `iteration` (0 for teacher forcing);
  // the batch order is a function of (seed, iteration, epoch) only
  void trainOneEpoch(int epoch, int iteration) {
    const EpochResult r = learner->trainEpoch(
        *store,
        common::deriveSeed(static_cast<uint64_t>(config.trainer.seed),
                         static_cast<uint64_t>(iteration)),
        epoch, [&](const UpdateResult& u) {
          if (u.skipped) {
            writeMetrics("nonfinite",
                         {{"update", learner->updates()}, {"loss", u.loss}}, {},
                         learner->updates());
            return;
          }
          if (learner->updates() % config.trainer.log_every_updates != 0)
            return;
          spdlog::info(
              "update {}: loss {:.4f} (action {:.4f}, progress {:.4f}), grad "
              "norm {:.3f}",
              learner->updates(), u.loss, u.action_loss, u.progress_loss,
              u.grad_norm);
          writeMetrics("update",
                       {{"update", learner->updates()},
                        {"epoch", epochsDone},
                        {"iteration", iteration},
                        {"loss", u.loss},
                        {"action_loss", u.action_loss},
                        {"progress_loss", u.progress_loss},
                        {"grad_norm", u.grad_norm},
                        {"steps", u.steps}},
                       {{"train/loss", u.loss},
                        {"train/action_loss", u.action_loss},
                        {"train/progress_loss", u.progress_loss},
                        {"train/grad_norm", u.grad_norm}},
                       learner->updates());
        });
    ++epochsDone;
    const double rate =
        r.seconds > 0 ? static_cast<double>(r.updates) / r.seconds : 0.0;
    spdlog::info(
        "epoch {} (iteration {}): {} updates ({} skipped) in {:.1f} s ({:.2f} "
        "updates/s), "
        "mean loss {:.4f} (action {:.4f}, progress {:.4f}), {} episodes in the "
        "store",
        epochsDone, iteration, r.updates, r.skipped, r.seconds, rate,
        r.mean.loss, r.mean.action_loss, r.mean.progress_loss, storeEpisodes);
    checkRanksAgree(strCat("after epoch ", epochsDone));
    writeMetrics("epoch",
                 {{"epoch", epochsDone},
                  {"iteration", iteration},
                  {"updates", r.updates},
                  {"skipped", r.skipped},
                  {"seconds", r.seconds},
                  {"updates_per_second", rate},
                  {"loss", r.mean.loss},
                  {"action_loss", r.mean.action_loss},
                  {"progress_loss", r.mean.progress_loss},
                  {"store_episodes", storeEpisodes},
                  {"inflection_coef", learner->inflectionCoef()}},
                 {{"epoch/loss", r.mean.loss},
                  {"epoch/action_loss", r.mean.action_loss},
                  {"epoch/progress_loss", r.mean.progress_loss},
                  {"epoch/updates_per_second", rate}},
                 epochsDone);
  }

  void finish(const std::string& reason) {
    // debug hook of the multi-process tests: every rank's final weights
    if (const char* dump = std::getenv("VLN_DEBUG_PARAMETER_DUMP_DIR");
        dump != nullptr && *dump != '\0')
      models::writeTensorFile(
          fs::path(dump) / strCat("rank", dist ? dist->rank() : 0, ".pt"),
          models::namedState(*policy));
    if (master())
      common::writeJsonFile(runDir / "finished.json",
                            {{"reason", reason},
                             {"last_checkpoint", progress.checkpoint_index},
                             {"best_checkpoint", progress.best_checkpoint},
                             {"best_spl", progress.best_spl},
                             {"updates", learner->updates()},
                             {"store_episodes", storeEpisodes},
                             {"store_bytes_per_step", storeBytesPerStep}},
                            2);
    spdlog::info("training finished ({}): last checkpoint {}, best {}", reason,
                 progress.checkpoint_index, progress.best_checkpoint);
  }

  void runTeacherForcing() {
    if (progress.epoch == 0) collect(0);
    for (int epoch = progress.epoch; epoch < config.trainer.epochs; ++epoch) {
      trainOneEpoch(epoch, 0);
      progress.epoch = epoch + 1;
      const bool evalDue = config.trainer.eval_during_training;
      saveCheckpointNow(evalDue);
      if (evalDue && evaluate(progress.checkpoint_index))
        return finish("early_stopping");
    }
    finish("completed");
  }

  void runDagger() {
    const int epochsPerIteration = config.trainer.dagger_epochs;
    for (int n = progress.dagger_iteration;
         n < config.trainer.dagger_iterations; ++n) {
      if (progress.epoch == 0) collect(n);
      for (int e = progress.epoch; e < epochsPerIteration; ++e) {
        trainOneEpoch(e, n);
        const bool last = e + 1 == epochsPerIteration;
        progress.dagger_iteration = last ? n + 1 : n;
        progress.epoch = last ? 0 : e + 1;
        const bool evalDue = last && config.trainer.eval_during_training;
        saveCheckpointNow(evalDue);
        if (evalDue && evaluate(progress.checkpoint_index))
          return finish("early_stopping");
      }
    }
    finish("completed");
  }
};

VlnTrainer::VlnTrainer(const ExperimentConfig& config, bool resume,
                       Distributed* dist)
    : impl_(std::make_unique<Impl>()) {
  impl_->config = config;
  impl_->dist = dist;
  impl_->setup(resume);
}

VlnTrainer::~VlnTrainer() = default;

void VlnTrainer::run() {
  Impl& t = *impl_;
  if (t.catchUpEvaluation()) return t.finish("early_stopping");
  const int patience = t.config.trainer.early_stopping_patience;
  if (patience > 0 && t.evalsSinceBest >= patience)
    return t.finish("early_stopping");
  if (t.dagger())
    t.runDagger();
  else
    t.runTeacherForcing();
}

}  // namespace vln::train
