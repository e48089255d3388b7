#include "train/RecollectTrainer.h"

#include <spdlog/spdlog.h>
#include <torch/torch.h>

#include <algorithm>

#include "common/Check.h"
#include "common/FileIo.h"
#include "common/Json.h"
#include "common/Progress.h"
#include "common/Random.h"
#include "models/ObservationEncoder.h"
#include "models/Policy.h"
#include "models/StateDict.h"
#include "train/CheckpointKeeper.h"
#include "train/ImitationLearner.h"
#include "train/MetricsLog.h"
#include "train/PeriodicEvaluator.h"
#include "train/Recollection.h"
#include "train/TrainingData.h"

namespace vln::train {
namespace fs = std::filesystem;

namespace {

// TrainingProgress::stage of this trainer's checkpoints
constexpr const char* kStage = "recollect";

// the batches of one update, each a list of indices into the pool
using Update = std::vector<std::vector<int64_t>>;

}  // namespace

struct RecollectTrainer::Impl {
  explicit Impl(const ExperimentConfig& runConfig) : config(runConfig) {}

  ExperimentConfig config;
  TrainingData data;
  RecollectionPool pool;
  StoreLayout layout;  ///< feature shapes of the batches (no store)

  std::shared_ptr<models::PolicyImpl> policy;
  models::ObservationEncoder encoder{nullptr};
  std::unique_ptr<ImitationLearner> learner;
  std::shared_ptr<rollout::SceneCache> scenes;
  std::unique_ptr<Recollector> recollector;
  std::unique_ptr<MetricsLog> metrics;
  std::unique_ptr<CheckpointKeeper> checkpoints;
  std::unique_ptr<PeriodicEvaluator> evaluator;

  TrainingProgress progress;
  bool resumed = false;

  // model.instruction_features rxr_text: each batch reads its episodes'
  // feature files (TrainingData::batchTextFeatures), as the store's batches
  bool readsTextFeatures() const {
    return config.model.usesInstruction() && config.model.usesTextFeatures();
  }

  // batches per optimizer step (gradient accumulation)
  int batchesPerUpdate() const {
    const TrainerConfig& t = config.trainer;
    return t.effective_batch_size > 0 ? t.effective_batch_size / t.batch_size
                                      : 1;
  }

  // --- setup ---------------------------------------------------------------

  void setup(bool resume) {
    const common::Stopwatch setupClock;
    const fs::path runDir = config.output.dir;
    const torch::Device device = models::modelDevice(config.model);
    torch::manual_seed(static_cast<uint64_t>(config.trainer.seed));
    data = TrainingData::load(config);
    pool = recollectionPool(data, config);
    int64_t steps = 0;
    for (const RecollectEpisode& e : pool.episodes) steps += e.length();
    spdlog::info(
        "recollect: {} episodes ({} steps) replay their ground truth; left "
        "out: {} without ground truth, {} longer than trainer.max_traj_len "
        "= {}",
        pool.episodes.size(), steps, pool.without_ground_truth,
        pool.over_max_traj_len, config.trainer.max_traj_len);
    scenes = std::make_shared<rollout::SceneCache>(config.sim);
    if (config.trainer.eval_during_training)
      evaluator = std::make_unique<PeriodicEvaluator>(config, scenes, nullptr);

    // the policy and the frozen encoders, in this order under the seed (as
    // VlnTrainer: the same initial weights as mode dagger)
    torch::Tensor embeddings;
    // GloVe only for token ids; rxr_text models have no word embedding
    if (config.model.usesInstruction() && !config.model.usesTextFeatures())
      embeddings = embeddingTensor(config);
    else if (readsTextFeatures())
      data.requireTextFeatureFiles(config);
    policy = models::makePolicy(config.model, embeddings);
    encoder = models::ObservationEncoder(config.model);
    encoder->loadPretrained();
    encoder->to(device);
    encoder->eval();
    if (config.model.usesRgb())
      layout.rgb_shape = models::rgbFeatureShape(config.model);
    if (config.model.usesDepth())
      layout.depth_shape = models::depthFeatureShape(config.model);
    layout.fp16 = false;

    // where to start: the last checkpoint (--resume), init_checkpoint or
    // fresh
    checkpoints = std::make_unique<CheckpointKeeper>(
        config, runDir / "checkpoints", /*writes=*/true);
    std::string source;
    const std::optional<Checkpoint> last =
        checkpoints->resumeFrom(resume, nullptr, source);
    resumed = last.has_value();
    const std::string& init = config.trainer.init_checkpoint;
    if (!resumed && !init.empty()) {
      models::loadStateStrict(*policy, readPolicyWeights(init), init);
      spdlog::info("initialised the policy from {}", init);
    }
    learner = std::make_unique<ImitationLearner>(policy, config);
    if (config.trainer.inflection_weight <= 0.0) {
      learner->setInflectionCoef(
          inverseInflectionFrequency(data.groundTruths()));
      spdlog::info(
          "inflection weight: {:.4f} (inverse inflection frequency of the "
          "ground truth)",
          learner->inflectionCoef());
    }
    if (resumed) {
      VLN_CHECK_ARG(last->progress.stage == kStage, "train --resume: ", source,
                    " was written by stage '", last->progress.stage,
                    "', not by trainer.mode recollect");
      models::loadStateStrict(*policy, last->policy, source);
      loadOptimizerState(learner->optimizer(), last->optimizer_state, source);
      restoreRngState(last->rng_state, source);
      progress = last->progress;
      learner->setUpdates(progress.updates);
      spdlog::info("resuming from {}: {} epochs done, {} updates", source,
                   progress.epoch, progress.updates);
    } else {
      progress = TrainingProgress{};
      progress.checkpoint_index = -1;
      progress.stage = kStage;
    }
    recollector = std::make_unique<Recollector>(config, scenes, encoder);

    metrics = std::make_unique<MetricsLog>(
        runDir / "metrics.jsonl",
        config.output.tensorboard ? runDir / "tb" : fs::path());
    metrics->write("start",
                   {{"resumed", resumed},
                    {"checkpoint", progress.checkpoint_index},
                    {"updates", progress.updates},
                    {"mode", kStage},
                    {"pool_episodes", pool.episodes.size()},
                    {"without_ground_truth", pool.without_ground_truth},
                    {"over_max_traj_len", pool.over_max_traj_len},
                    {"setup_seconds", setupClock.seconds()}},
                   {}, progress.updates);
  }

  // --- one epoch ------------------------------------------------------------

  // the updates of epoch `epoch`: its batches (a function of the seed and
  // the epoch only) in groups of batchesPerUpdate()
  std::vector<Update> epochUpdates(int epoch) const {
    std::vector<int32_t> lengths;
    lengths.reserve(pool.episodes.size());
    for (const RecollectEpisode& e : pool.episodes)
      lengths.push_back(e.length());
    const auto batches = epochBatches(
        lengths, config.trainer.batch_size,
        common::deriveSeed(static_cast<uint64_t>(config.trainer.seed), 0),
        epoch);
    const auto k = static_cast<size_t>(batchesPerUpdate());
    std::vector<Update> updates;
    for (size_t i = 0; i < batches.size(); i += k)
      updates.emplace_back(
          batches.begin() + static_cast<std::ptrdiff_t>(i),
          batches.begin() +
              static_cast<std::ptrdiff_t>(std::min(batches.size(), i + k)));
    return updates;
  }

  void trainEpoch(int epoch) {
    const std::vector<Update> updates = epochUpdates(epoch);
    EpochResult result;
    result.lr = learner->learningRate();
    ReplayStats replayed;
    const common::Stopwatch clock;
    common::ProgressLine line(strCat("recollect epoch ", epoch),
                              static_cast<int64_t>(updates.size()), "updates");
    size_t next = 0;
    while (next < updates.size()) {
      // simulate whole updates until preload_size episodes are held
      const size_t first = next;
      std::vector<RecollectEpisode> load;
      while (next < updates.size() &&
             (next == first || static_cast<int64_t>(load.size()) <
                                   config.trainer.preload_size)) {
        for (const auto& batch : updates[next])
          for (int64_t i : batch)
            load.push_back(pool.episodes[static_cast<size_t>(i)]);
        ++next;
      }
      std::vector<RecollectedEpisode> episodes =
          recollector->replay(load, &replayed);

      // then train on them, in order, update by update
      size_t position = 0;
      for (size_t u = first; u < next; ++u) {
        std::vector<EpisodeBatch> batches;
        for (const auto& indices : updates[u]) {
          std::vector<StoredEpisode> members;
          std::vector<StoredEpisodeKey> keys;
          for (size_t j = 0; j < indices.size(); ++j) {
            members.push_back(std::move(episodes[position++].stored));
            keys.push_back(members.back().key);
          }
          batches.push_back(batchEpisodes(members, layout));
          batches.back().indices = indices;
          if (readsTextFeatures())
            batches.back().text_features = data.batchTextFeatures(config, keys);
        }
        const UpdateResult r = batches.size() == 1
                                   ? learner->update(batches.front())
                                   : learner->updateAccumulated(batches);
        learner->addToEpoch(r, epoch, result);
        logUpdate(r, learner->updates(), progress.epoch, /*iteration=*/0,
                  config, metrics.get());
        line.advance();
      }
    }
    ImitationLearner::finishEpoch(result);
    result.seconds = clock.seconds();
    logEpoch(result, progress.epoch + 1, /*iteration=*/0,
             static_cast<int64_t>(pool.episodes.size()),
             learner->inflectionCoef(), metrics.get());
    logReplay(replayed, result, epoch);
  }

  // the simulation's share of the epoch and its agreement with the ground
  // truth's locations
  void logReplay(const ReplayStats& r, const EpochResult& epoch,
                 int epochIndex) {
    const double fps =
        r.seconds > 0 ? static_cast<double>(r.steps) / r.seconds : 0.0;
    auto level =
        r.off_ground_truth > 0 ? spdlog::level::warn : spdlog::level::info;
    spdlog::log(level,
                "recollect epoch {}: replayed {} episodes ({} steps) in {:.1f} "
                "s ({:.1f} frames/s) of the epoch's {:.1f} s; {} episodes off "
                "their ground truth's locations (largest error {:.4f} m)",
                epochIndex + 1, r.episodes, r.steps, r.seconds, fps,
                epoch.seconds, r.off_ground_truth, r.max_location_error);
    metrics->write("recollect",
                   {{"epoch", progress.epoch + 1},
                    {"episodes", r.episodes},
                    {"steps", r.steps},
                    {"simulate_seconds", r.seconds},
                    {"epoch_seconds", epoch.seconds},
                    {"frames_per_second", fps},
                    {"off_ground_truth", r.off_ground_truth},
                    {"max_location_error", r.max_location_error},
                    {"batches_per_update", batchesPerUpdate()}},
                   {{"recollect/frames_per_second", fps},
                    {"recollect/off_ground_truth",
                     static_cast<double>(r.off_ground_truth)}},
                   progress.epoch + 1);
  }

  // --- checkpoints and evaluation -------------------------------------------

  void saveCheckpoint(bool evaluateAfter) {
    progress.epoch += 1;
    progress.checkpoint_index += 1;
    progress.updates = learner->updates();
    progress.episodes_collected = 0;  // nothing is stored
    progress.extra["evals_since_best"] = checkpoints->evalsSinceBest();
    progress.extra["epochs_done"] = progress.epoch;
    progress.extra["eval_due"] = evaluateAfter;
    progress.extra["inflection_coef"] = learner->inflectionCoef();
    progress.extra["pool_episodes"] = pool.episodes.size();
    checkpoints->save(trainingCheckpoint(experimentConfigYaml(config), *policy,
                                         learner->optimizer(), progress));
  }

  // evaluates the latest checkpoint's policy; true when training should stop
  bool evaluate() {
    return evaluator->evaluateLatest(progress, *checkpoints, learner->updates(),
                                     policy, encoder, metrics.get());
  }

  // an evaluation that was due after the last checkpoint but did not finish
  bool catchUpEvaluation() {
    return resumed && evaluator &&
           evaluator->catchUp(progress, *checkpoints, learner->updates(),
                              policy, encoder, metrics.get());
  }

  void finish(const std::string& reason) {
    common::writeJsonFile(fs::path(config.output.dir) / "finished.json",
                          {{"reason", reason},
                           {"mode", kStage},
                           {"last_checkpoint", progress.checkpoint_index},
                           {"best_checkpoint", progress.best_checkpoint},
                           {"best_spl", progress.best_spl},
                           {"updates", learner->updates()},
                           {"pool_episodes", pool.episodes.size()}},
                          2);
    spdlog::info("training finished ({}): last checkpoint {}, best {}", reason,
                 progress.checkpoint_index, progress.best_checkpoint);
  }
};

RecollectTrainer::RecollectTrainer(const ExperimentConfig& config, bool resume)
    : impl_(std::make_unique<Impl>(config)) {
  impl_->setup(resume);
}

RecollectTrainer::~RecollectTrainer() = default;

// The epochs: replay and train, a checkpoint after each, evaluate when
// configured, stop early when the patience runs out.
void RecollectTrainer::run() {
  Impl& t = *impl_;
  if (t.catchUpEvaluation() || t.checkpoints->patienceExhausted())
    return t.finish("early_stopping");
  const bool evaluate = t.evaluator != nullptr;
  while (t.progress.epoch < t.config.trainer.epochs) {
    t.trainEpoch(t.progress.epoch);
    t.saveCheckpoint(evaluate);
    if (evaluate && t.evaluate()) return t.finish("early_stopping");
  }
  t.finish("completed");
}

}  // namespace vln::train
