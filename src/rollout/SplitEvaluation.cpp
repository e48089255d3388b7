#include "rollout/SplitEvaluation.h"

#include <algorithm>
#include <cstdio>

#include "common/Check.h"
#include "common/Progress.h"
#include "data/RxrPredictions.h"

namespace vln::rollout {
namespace fs = std::filesystem;

SplitEvaluation evaluateSplit(Agent& agent, const data::Split& split,
                              const std::shared_ptr<SceneCache>& scenes,
                              const sim::SimConfig& sim,
                              const sim::TaskConfig& task,
                              const EvalConfig& eval,
                              const SplitEvaluationOptions& options) {
  VLN_CHECK_ARG(options.num_shards == 1 || options.sum,
                "evaluateSplit(): ", options.num_shards,
                " shards need a sum over the processes");
  SplitEvaluation out;
  out.checkpoint = options.checkpoint;
  out.split = split.name;

  // this process's episodes: every num_shards-th from its shard on
  std::vector<data::Episode> shard;
  const std::vector<data::Episode>* episodes = &split.episodes;
  if (options.num_shards > 1) {
    for (size_t i = static_cast<size_t>(options.shard);
         i < split.episodes.size();
         i += static_cast<size_t>(options.num_shards))
      shard.push_back(split.episodes[i]);
    episodes = &shard;
  }
  out.episodes = static_cast<int>(episodes->size());

  VectorEnv envs(eval.num_envs, sim, task, scenes, eval.threads);
  common::ProgressLine line(
      "evaluate " + (options.label.empty() ? "" : options.label + " ") +
          split.name,
      static_cast<int64_t>(episodes->size()), "episodes");
  common::Stopwatch clock;
  out.result = evaluateEpisodes(
      agent, envs, *episodes, split.groundTruth.get(), eval,
      [&](int, int) { line.advance(); }, options.observer);
  out.seconds = clock.seconds();
  for (const EpisodeResult& e : out.result.episodes)
    out.steps += e.record.steps_taken;
  out.stats = options.num_shards > 1 ? combineStats(out.result, options.sum)
                                     : out.result.stats;
  out.scored = out.stats.num_episodes > 0;
  if (options.out_dir.empty()) return out;

  // stats over the scored episodes, the per-episode file, the leaderboard
  // predictions of the unscored ones (of all, when asked)
  if (out.scored)
    out.files.push_back(
        writeStatsFile(options.out_dir, out.checkpoint, split.name, out.stats));
  if (options.save_episodes) {
    const fs::path file =
        options.out_dir / episodesFileName(out.checkpoint, split.name);
    writeEpisodesFile(file, out.result.episodes);
    out.files.push_back(file);
  }
  std::vector<EpisodeRecord> unscored;
  for (size_t i = 0; i < out.result.episodes.size(); ++i)
    if (!out.result.scored[i] || options.predictions_of_scored)
      unscored.push_back(out.result.episodes[i].record);
  if (!unscored.empty()) {
    const fs::path file =
        options.out_dir / predictionsFileName(out.checkpoint, split.name);
    writeLeaderboardFile(file, unscored);
    out.files.push_back(file);
  }
  // RxR episodes: the RxR-Habitat inference file (VLN-CE's INFERENCE
  // FORMAT rxr), scored or not; it needs every episode's path, so only a
  // process that ran the whole split writes it
  if (options.num_shards == 1 && !episodes->empty() &&
      std::all_of(episodes->begin(), episodes->end(),
                  [](const data::Episode& e) {
                    return e.instruction.instruction_id.has_value();
                  })) {
    std::vector<data::RxrPrediction> predictions;
    for (size_t i = 0; i < out.result.episodes.size(); ++i)
      predictions.push_back({*(*episodes)[i].instruction.instruction_id,
                             data::rxrPathFromPositions(
                                 out.result.episodes[i].record.positions)});
    const fs::path file =
        options.out_dir / rxrPredictionsFileName(out.checkpoint, split.name);
    data::writeRxrPredictions(file, std::move(predictions));
    out.files.push_back(file);
  }
  return out;
}

SplitStats combineStats(const EvaluationResult& mine,
                        const SumOverProcesses& sum) {
  constexpr size_t kCount = kMetricFields.size();
  std::vector<double> sums(kCount + 1, 0.0);
  for (size_t i = 0; i < mine.episodes.size(); ++i) {
    if (!mine.scored[i]) continue;
    for (size_t f = 0; f < kCount; ++f)
      sums[f] += mine.episodes[i].metrics.*kMetricFields[f].second;
    sums[kCount] += 1.0;
  }
  sums = sum(sums);
  SplitStats all;
  all.num_episodes = static_cast<int>(sums[kCount]);
  if (all.num_episodes == 0) return all;
  for (size_t f = 0; f < kCount; ++f)
    all.mean.*kMetricFields[f].second = sums[f] / sums[kCount];
  return all;
}

std::string metricsText(const EpisodeMetrics& m) {
  char text[160];
  std::snprintf(text, sizeof(text),
                "TL %.2f NE %.2f nDTW %.3f OS %.3f SR %.3f SPL %.3f",
                m.path_length, m.distance_to_goal, m.ndtw, m.oracle_success,
                m.success, m.spl);
  return text;
}

std::string summaryLine(const SplitEvaluation& evaluation) {
  std::string line = "ckpt " + std::to_string(evaluation.checkpoint) + " " +
                     evaluation.split + ": ";
  if (evaluation.skipped)
    return line +
           "skipped (already evaluated): " + metricsText(evaluation.stats.mean);
  char head[200];
  const double seconds = std::max(evaluation.seconds, 1e-9);
  std::snprintf(head, sizeof(head),
                "%d episodes, %lld steps in %.1f s (%.2f episodes/s, %.0f "
                "steps/s): ",
                evaluation.episodes, static_cast<long long>(evaluation.steps),
                evaluation.seconds, evaluation.episodes / seconds,
                static_cast<double>(evaluation.steps) / seconds);
  line += head;
  if (!evaluation.scored)
    return line + "no goals (leaderboard predictions written)";
  return line + metricsText(evaluation.stats.mean);
}

std::string predictionsFileName(int checkpoint, std::string_view split) {
  return "predictions_ckpt_" + std::to_string(checkpoint) + "_" +
         std::string(split) + ".json";
}

std::string rxrPredictionsFileName(int checkpoint, std::string_view split) {
  return "rxr_predictions_ckpt_" + std::to_string(checkpoint) + "_" +
         std::string(split) + ".jsonl";
}

}  // namespace vln::rollout
