#include "train/VlnTrainer.h"

#include <spdlog/spdlog.h>

#include <cstdlib>

#include "common/Check.h"
#include "common/FileIo.h"
#include "common/Json.h"
#include "common/Progress.h"
#include "common/Random.h"
#include "models/ObservationEncoder.h"
#include "models/Policy.h"
#include "models/StateDict.h"
#include "train/CheckpointKeeper.h"
#include "train/Collector.h"
#include "train/Distributed.h"
#include "train/DistributedTraining.h"
#include "train/FeatureStore.h"
#include "train/ImitationLearner.h"
#include "train/MetricsLog.h"
#include "train/PeriodicEvaluator.h"
#include "train/TrainingData.h"
#include "train/TrainingSchedule.h"

namespace vln::train {
namespace fs = std::filesystem;

struct VlnTrainer::Impl {
  Impl(const ExperimentConfig& runConfig, Distributed* group)
      : config(runConfig), schedule(runConfig.trainer), dist(group) {}

  ExperimentConfig config;
  TrainingSchedule schedule;
  Distributed* dist;  ///< this rank's group; null: one process
  TrainingData data;

  std::shared_ptr<models::PolicyImpl> policy;
  models::ObservationEncoder encoder{nullptr};
  std::unique_ptr<ImitationLearner> learner;
  std::unique_ptr<FeatureStore> store;
  std::shared_ptr<rollout::SceneCache> scenes;
  std::unique_ptr<Collector> collector;
  std::unique_ptr<MetricsLog> metrics;  ///< rank 0 only
  std::unique_ptr<CheckpointKeeper> checkpoints;
  std::unique_ptr<PeriodicEvaluator> evaluator;

  TrainingProgress progress;
  bool resumed = false;
  int64_t epochsDone = 0;
  StoreTotals storeTotals;  ///< over all ranks, after each round

  // rank 0 (or the only process) writes the run's files
  bool master() const { return !dist || dist->isMaster(); }

  // the ranks' policies must be bitwise identical (same updates applied)
  void checkRanksAgree(const std::string& when) {
    if (dist) dist->checkIdentical(*policy, when);
  }

  // --- setup ---------------------------------------------------------------

  void setup(bool resume) {
    const common::Stopwatch setupClock;
    const fs::path runDir = config.output.dir;
    const torch::Device device = models::modelDevice(config.model);
    torch::manual_seed(static_cast<uint64_t>(config.trainer.seed));
    data = TrainingData::load(config);
    scenes = std::make_shared<rollout::SceneCache>(config.sim);
    if (config.trainer.eval_during_training)
      evaluator = std::make_unique<PeriodicEvaluator>(config, scenes, dist);

    // the policy and the frozen encoders, in this order under the seed
    torch::Tensor embeddings;
    // GloVe only for token ids; rxr_text models have no word embedding
    if (config.model.usesInstruction() && !config.model.usesTextFeatures())
      embeddings = embeddingTensor(config);
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
    if (dist) checkRoundsFitRanks();

    // where to start: the last checkpoint (--resume), init_checkpoint
    // (read by rank 0; the others receive its weights below) or fresh
    checkpoints = std::make_unique<CheckpointKeeper>(
        config, runDir / "checkpoints", master());
    std::string source;
    const std::optional<Checkpoint> last =
        checkpoints->resumeFrom(resume, dist, source);
    resumed = last.has_value();
    const std::string& init = config.trainer.init_checkpoint;
    if (!resumed && !init.empty() && master()) {
      models::loadStateStrict(*policy, readPolicyWeights(init), init);
      spdlog::info("initialised the policy from {}", init);
    }
    learner = std::make_unique<ImitationLearner>(policy, config);
    if (dist) learner->setDistributed(dist);
    if (config.model.usesInstruction() && config.model.usesTextFeatures())
      useTextFeatures();
    if (config.trainer.inflection_weight <= 0.0) {
      learner->setInflectionCoef(
          inverseInflectionFrequency(data.groundTruths()));
      spdlog::info(
          "inflection weight: {:.4f} (inverse inflection frequency of the "
          "ground truth)",
          learner->inflectionCoef());
    }
    if (resumed) {
      models::loadStateStrict(*policy, last->policy, source);
      loadOptimizerState(learner->optimizer(), last->optimizer_state, source);
      restoreRngState(last->rng_state, source);
      progress = last->progress;
      learner->setUpdates(progress.updates);
      epochsDone = progress.extra.value("epochs_done", int64_t{0});
      spdlog::info(
          "resuming from {}: stage {}, {} DAgger iterations and {} epochs "
          "done, {} updates",
          source, progress.stage, progress.dagger_iteration, progress.epoch,
          progress.updates);
    } else {
      progress = TrainingProgress{};
      progress.checkpoint_index = -1;
      progress.stage = schedule.dagger() ? "dagger" : "teacher_forcing";
    }

    store = openFeatureStore(
        config, dist ? storeShardDir(runDir, dist->rank()) : runDir / "store");
    storeTotals = totalsOverRanks(*store, dist);
    if (master()) {
      metrics = std::make_unique<MetricsLog>(
          runDir / "metrics.jsonl",
          config.output.tensorboard ? runDir / "tb" : fs::path());
      // where this process's records begin (a learning curve's wall time
      // adds up the processes of a resumed run: viz/LearningCurve.h)
      metrics->write("start",
                     {{"resumed", resumed},
                      {"checkpoint", progress.checkpoint_index},
                      {"updates", progress.updates},
                      {"setup_seconds", setupClock.seconds()}},
                     {}, progress.updates);
    }
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

  // rxr_text: every pool episode's feature file exists (checked before
  // any collection), batches read them by store key, DAgger's policy by
  // episode
  void useTextFeatures() {
    data.requireTextFeatureFiles(config);
    learner->setTextFeatures(
        [this](const FeatureStore& s, std::span<const int64_t> indices) {
          return data.batchTextFeatures(config, s, indices);
        });
  }

  // every rank needs at least one episode of every collection round
  void checkRoundsFitRanks() const {
    const size_t smallest = schedule.smallestRound(data.pool.size());
    VLN_CHECK_ARG(
        smallest >= static_cast<size_t>(dist->worldSize()),
        "train: WORLD_SIZE = ", dist->worldSize(), " is larger than the ",
        smallest, " episodes of a collection round (",
        schedule.dagger() ? "trainer.dagger_episodes or the training pool"
                          : "the training pool: dataset.train_split",
        config.trainer.use_aug ? " + dataset.aug_split" : "",
        ", capped by dataset.max_train_episodes): every rank needs at "
        "least one episode");
  }

  // --- the schedule's steps -------------------------------------------------

  void collect(int iteration) {
    CollectionRound round;
    round.iteration = iteration;
    round.beta = schedule.beta(iteration);
    round.seed = static_cast<uint64_t>(config.trainer.seed);
    for (size_t i : schedule.roundEpisodes(iteration, data.pool.size())) {
      round.episodes.push_back(data.pool[i]);
      round.sources.push_back(data.sources[i]);
    }
    if (dist) {
      round.shard = dist->rank();
      round.num_shards = dist->worldSize();
    }
    if (!collector) {
      collector = std::make_unique<Collector>(config, scenes, encoder);
      if (config.model.usesInstruction() && config.model.usesTextFeatures())
        collector->setInstructionFeatures(data.textFeatureSource(config));
    }
    CollectionStats stats = collector->collect(
        round, *store, round.beta < 1.0 ? policy : nullptr,
        round.beta >= 1.0 ? data.train.groundTruth.get() : nullptr);
    if (dist) {
      // every shard is complete before anyone trains; the record covers the
      // whole round (its wall time is the slowest rank's)
      dist->waitForAll(strCat("the end of collection round ", iteration));
      stats = stats.overRanks(
          [&](const std::vector<double>& v) { return dist->allReduceSum(v); },
          [&](int64_t v) { return dist->allReduceMax({v}).front(); });
    }
    storeTotals = totalsOverRanks(*store, dist);
    if (master())
      logCollection(stats, round, storeTotals, data.train.name,
                    config.trainer.expert == "reference_path", metrics.get());
  }

  // epoch `epoch` of iteration `iteration`; its batch order is a function
  // of (seed, iteration, epoch) only
  void trainEpoch(int iteration, int epoch) {
    // from the indices alone, so a resumed run trains at the same rate
    setAdamLearningRate(learner->optimizer(),
                        schedule.learningRate(iteration, epoch));
    const EpochResult r = learner->trainEpoch(
        *store,
        common::deriveSeed(static_cast<uint64_t>(config.trainer.seed),
                           static_cast<uint64_t>(iteration)),
        epoch, [&](const UpdateResult& u) {
          logUpdate(u, learner->updates(), epochsDone, iteration, config,
                    metrics.get());
        });
    ++epochsDone;
    checkRanksAgree(strCat("after epoch ", epochsDone));
    logEpoch(r, epochsDone, iteration, storeTotals.episodes,
             learner->inflectionCoef(), metrics.get());
  }

  void saveCheckpoint(const ScheduledEpoch& done) {
    progress.dagger_iteration = done.iterations_done;
    progress.epoch = done.epochs_done;
    progress.checkpoint_index += 1;
    progress.updates = learner->updates();
    progress.episodes_collected = storeTotals.episodes;
    progress.extra["evals_since_best"] = checkpoints->evalsSinceBest();
    progress.extra["epochs_done"] = epochsDone;
    progress.extra["eval_due"] = done.evaluate_after;
    progress.extra["inflection_coef"] = learner->inflectionCoef();
    if (dist) progress.extra["world_size"] = dist->worldSize();
    if (!master()) return;  // the progress above is kept on every rank
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
    // debug hook of the multi-process tests: every rank's final weights
    if (const char* dump = std::getenv("VLN_DEBUG_PARAMETER_DUMP_DIR");
        dump != nullptr && *dump != '\0')
      models::writeTensorFile(
          fs::path(dump) / strCat("rank", dist ? dist->rank() : 0, ".pt"),
          models::namedState(*policy));
    if (master())
      common::writeJsonFile(fs::path(config.output.dir) / "finished.json",
                            {{"reason", reason},
                             {"last_checkpoint", progress.checkpoint_index},
                             {"best_checkpoint", progress.best_checkpoint},
                             {"best_spl", progress.best_spl},
                             {"updates", learner->updates()},
                             {"store_episodes", storeTotals.episodes},
                             {"store_bytes_per_step", storeTotals.bytes_per_step}},
                            2);
    spdlog::info("training finished ({}): last checkpoint {}, best {}", reason,
                 progress.checkpoint_index, progress.best_checkpoint);
  }
};

VlnTrainer::VlnTrainer(const ExperimentConfig& config, bool resume,
                       Distributed* dist)
    : impl_(std::make_unique<Impl>(config, dist)) {
  impl_->setup(resume);
}

VlnTrainer::~VlnTrainer() = default;

// The schedule: collect a round, train its epochs with a checkpoint after
// each, evaluate when due, stop early when the patience runs out.
void VlnTrainer::run() {
  Impl& t = *impl_;
  if (t.catchUpEvaluation() || t.checkpoints->patienceExhausted())
    return t.finish("early_stopping");
  const auto todo = t.schedule.remaining(t.progress.dagger_iteration,
                                         t.progress.epoch);
  for (const ScheduledIteration& iteration : todo) {
    if (iteration.collect) t.collect(iteration.iteration);
    for (const ScheduledEpoch& epoch : iteration.epochs) {
      t.trainEpoch(iteration.iteration, epoch.epoch);
      t.saveCheckpoint(epoch);
      if (epoch.evaluate_after && t.evaluate())
        return t.finish("early_stopping");
    }
  }
  t.finish("completed");
}

}  // namespace vln::train
