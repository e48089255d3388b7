#include "train/PeriodicEvaluator.h"

#include <spdlog/spdlog.h>

#include "common/Check.h"
#include "rollout/ObservationBatch.h"
#include "rollout/PolicyAgent.h"
#include "rollout/SplitEvaluation.h"
#include "train/CheckpointKeeper.h"
#include "train/Distributed.h"
#include "viz/EpisodeMedia.h"

namespace vln::train {
namespace fs = std::filesystem;

namespace {

// writes the media of one split's evaluation as TensorBoard images and
// lists them in an "eval_media" record
void writeMedia(std::vector<viz::EpisodeMediaItem> items,
                const std::string& split, int index, MetricsLog& metrics) {
  if (items.empty()) return;
  nlohmann::json media = nlohmann::json::array();
  for (const viz::EpisodeMediaItem& item : items) {
    const std::string tag = "eval/" + split + "/" +
                            viz::mediaKindName(item.kind) + "/episode_" +
                            item.episode_id;
    metrics.writeImage(tag, index, item.encoded, item.width, item.height,
                       item.channels);
    media.push_back({{"tag", tag},
                     {"kind", viz::mediaKindName(item.kind)},
                     {"episode_id", item.episode_id},
                     {"width", item.width},
                     {"height", item.height},
                     {"frames", item.frames},
                     {"bytes", item.encoded.size()}});
  }
  metrics.write("eval_media",
                {{"checkpoint", index}, {"split", split}, {"media", media}}, {},
                index);
}

}  // namespace

PeriodicEvaluator::PeriodicEvaluator(
    const ExperimentConfig& config, std::shared_ptr<rollout::SceneCache> scenes,
    Distributed* dist)
    : config_(config),
      dir_(fs::path(config.output.dir) / "eval"),
      scenes_(std::move(scenes)),
      dist_(dist) {
  const rollout::EvalConfig& ec = config.eval;
  const int cap =
      ec.train_eval_episodes >= 0 ? ec.train_eval_episodes : ec.episodes;
  for (const auto& name : ec.splits) {
    splits_.push_back(data::loadDatasetSplit(config.dataset, name, cap));
    VLN_CHECK_ARG(splits_.back().hasGoals || splits_.back().episodes.empty(),
                  "train: eval.splits: split '", name, "' under '",
                  config.dataset.data_path,
                  "' has no goals to validate on (leave it to the eval "
                  "binary)");
    if (config.model.usesInstruction() && config.model.usesTextFeatures()) {
      std::vector<const data::Episode*> episodes;
      for (const data::Episode& e : splits_.back().episodes)
        episodes.push_back(&e);
      rollout::requireRxrTextFeatureFiles(config.dataset.textFeaturesPath(),
                                          name, episodes);
    }
  }
}

double PeriodicEvaluator::evaluate(
    int index, int64_t updates,
    const std::shared_ptr<models::PolicyImpl>& policy,
    const models::ObservationEncoder& encoder, MetricsLog* metrics) {
  const rollout::EvalConfig& ec = config_.eval;
  const double spl = evaluateAgent(
      index, updates,
      [&](const data::Split& split) {
        auto agent = std::make_unique<rollout::PolicyAgent>(
            policy, encoder, ec.num_envs, ec.sample_actions,
            static_cast<uint64_t>(ec.seed),
            config_.dataset.max_instruction_length);
        if (config_.model.usesInstruction() && config_.model.usesTextFeatures())
          agent->setInstructionFeatures(rollout::rxrTextFeatureSource(
              config_.dataset.textFeaturesPath(), split.name,
              config_.model.text_feature_dim));
        return agent;
      },
      metrics);
  policy->train();
  return spl;
}

double PeriodicEvaluator::evaluateAgent(int index, int64_t updates,
                                        const AgentForSplit& agentFor,
                                        MetricsLog* metrics) {
  const rollout::EvalConfig& ec = config_.eval;
  const bool writes = !dist_ || dist_->isMaster();
  // media only where TensorBoard is written (rank 0) and asked for
  const bool media = metrics != nullptr && metrics->tensorboard() &&
                     (ec.tensorboard_maps > 0 || ec.tensorboard_videos > 0);
  double selectionSpl = -1.0;
  for (const data::Split& split : splits_) {
    std::unique_ptr<viz::EpisodeMedia> observer;
    if (media) {
      viz::MediaConfig mc;
      mc.maps = ec.tensorboard_maps;
      mc.videos = ec.tensorboard_videos;
      mc.success_distance = config_.task.success_distance;
      observer = std::make_unique<viz::EpisodeMedia>(mc);
    }
    const std::unique_ptr<rollout::Agent> agent = agentFor(split);
    rollout::SplitEvaluationOptions options;
    options.checkpoint = index;
    options.observer = observer.get();
    if (writes) options.out_dir = dir_;
    if (dist_) {
      options.shard = dist_->rank();
      options.num_shards = dist_->worldSize();
      const std::string what =
          strCat("the evaluation of checkpoint ", index, " on ", split.name);
      // the ranks finish their shares at different times: wait on the
      // store (waitForAll) rather than inside the collective's timeout
      options.gather = [this, what](const std::string& mine) {
        dist_->waitForAll(what);
        return dist_->allGatherBytes(mine);
      };
    }
    const rollout::SplitEvaluation result = rollout::evaluateSplit(
        *agent, split, scenes_, config_.sim, config_.task, ec, options);
    spdlog::info("{}", rollout::summaryLine(result));
    if (metrics) {
      const nlohmann::json values = rollout::metricsToJson(result.stats.mean);
      nlohmann::json record = values;
      record["checkpoint"] = index;
      record["updates"] = updates;
      record["split"] = split.name;
      record["num_episodes"] = result.stats.num_episodes;
      std::vector<std::pair<std::string, double>> scalars;
      for (const auto& [key, value] : values.items())
        scalars.emplace_back("eval/" + split.name + "/" + key,
                             value.get<double>());
      metrics->write("eval", record, scalars, index);
    }
    if (observer) writeMedia(observer->take(), split.name, index, *metrics);
    if (split.name == ec.selection_split) selectionSpl = result.stats.mean.spl;
  }
  return selectionSpl;
}

std::optional<double> PeriodicEvaluator::recorded(int index) {
  const bool master = !dist_ || dist_->isMaster();
  bool done = master;
  for (const data::Split& split : splits_)
    done = done && fs::exists(dir_ / rollout::statsFileName(index, split.name));
  if (dist_) done = dist_->broadcastBytes(done ? "1" : "0") == "1";
  if (!done) return std::nullopt;
  double spl = -1.0;
  if (master)
    for (const data::Split& split : splits_)
      if (split.name == config_.eval.selection_split)
        spl = rollout::readStatsFile(dir_ /
                                     rollout::statsFileName(index, split.name))
                  .mean.spl;
  if (dist_) spl = dist_->allReduceSum({master ? spl : 0.0}).front();
  return spl;
}

bool PeriodicEvaluator::evaluateLatest(
    TrainingProgress& progress, CheckpointKeeper& keeper, int64_t updates,
    const std::shared_ptr<models::PolicyImpl>& policy,
    const models::ObservationEncoder& encoder, MetricsLog* metrics) {
  const int index = progress.checkpoint_index;
  const double spl = evaluate(index, updates, policy, encoder, metrics);
  return keeper.recordEvaluation(progress, index, spl);
}

bool PeriodicEvaluator::catchUp(
    TrainingProgress& progress, CheckpointKeeper& keeper, int64_t updates,
    const std::shared_ptr<models::PolicyImpl>& policy,
    const models::ObservationEncoder& encoder, MetricsLog* metrics) {
  if (!progress.extra.value("eval_due", false)) return false;
  const int index = progress.checkpoint_index;
  // finished before the interruption: fold its result in from the files
  if (const std::optional<double> spl = recorded(index))
    return keeper.recordEvaluation(progress, index, *spl);
  spdlog::info(
      "evaluating checkpoint {} (its evaluation did not finish before the "
      "interruption)",
      index);
  return evaluateLatest(progress, keeper, updates, policy, encoder, metrics);
}

}  // namespace vln::train
