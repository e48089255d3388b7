#include "rollout/SplitEvaluation.h"

#include <algorithm>
#include <cstdio>

#include "common/Check.h"
#include "common/Json.h"
#include "common/Progress.h"
#include "data/RxrPredictions.h"

namespace vln::rollout {
namespace fs = std::filesystem;

namespace {

// One shard's episodes and scored flags as bytes for the gather: the JSON of
// the per-episode file (episodesToJson()) plus the flags, in CBOR, whose
// binary numbers bring every metric and coordinate back bit for bit (inf
// and NaN too), so stats computed from gathered episodes are one process's.
std::string shardBytes(const EvaluationResult& shard) {
  nlohmann::json json = episodesToJson(shard.episodes);
  json["scored"] = shard.scored;
  const std::vector<uint8_t> cbor = nlohmann::json::to_cbor(json);
  return std::string(cbor.begin(), cbor.end());
}

// The whole split's result from every shard's bytes (shard s ran episodes s,
// s + numShards, ... of the split); this process's own episodes (`mine`,
// shard `own`) are kept as they are, waypoint choices included.
EvaluationResult mergeShards(EvaluationResult mine, int own, int numShards,
                             const std::vector<std::string>& bytes,
                             const data::Split& split) {
  VLN_CHECK_IO(bytes.size() == static_cast<size_t>(numShards),
               "evaluateSplit(): split '", split.name,
               "': the gather returned ", bytes.size(),
               " shards' episodes, expected ", numShards);
  const size_t n = bytes.size();
  const size_t total = split.episodes.size();
  EvaluationResult all;
  all.episodes.resize(total);
  all.scored.assign(total, 0);
  for (size_t s = 0; s < n; ++s) {
    const std::string source =
        strCat("evaluateSplit(): split '", split.name,
               "': the episodes of shard ", s, " of ", n);
    std::vector<EpisodeResult> episodes;
    std::vector<uint8_t> scored;
    if (s == static_cast<size_t>(own)) {
      episodes = std::move(mine.episodes);
      scored = std::move(mine.scored);
    } else {
      nlohmann::json json;
      try {
        json = nlohmann::json::from_cbor(bytes[s]);
      } catch (const nlohmann::json::exception& error) {
        throw std::runtime_error(
            strCat(source, " are not readable: ", error.what()));
      }
      episodes = episodesFromJson(json, source);
      scored =
          common::requireField<std::vector<uint8_t>>(json, "scored", source);
    }
    // every n-th episode from s on, in the split's order
    const size_t expected = s < total ? (total - s + n - 1) / n : 0;
    VLN_CHECK_IO(episodes.size() == expected && scored.size() == expected,
                 source, " are ", episodes.size(), " episodes with ",
                 scored.size(), " scored flags, expected ", expected,
                 " (do the processes evaluate the same split?)");
    for (size_t k = 0; k < expected; ++k) {
      const size_t i = s + k * n;
      const std::string id = std::to_string(split.episodes[i].episode_id);
      VLN_CHECK_IO(episodes[k].record.episode_id == id, source, ": entry ", k,
                   " is episode '", episodes[k].record.episode_id,
                   "', expected the split's episode ", i, " '", id,
                   "' (do the processes evaluate the same split?)");
      all.episodes[i] = std::move(episodes[k]);
      all.scored[i] = scored[k];
    }
  }
  all.stats = scoredStats(all);
  return all;
}

}  // namespace

SplitEvaluation evaluateSplit(Agent& agent, const data::Split& split,
                              const std::shared_ptr<SceneCache>& scenes,
                              const sim::SimConfig& sim,
                              const sim::TaskConfig& task,
                              const EvalConfig& eval,
                              const SplitEvaluationOptions& options) {
  VLN_CHECK_ARG(options.num_shards >= 1 && options.shard >= 0 &&
                    options.shard < options.num_shards,
                "evaluateSplit(): shard ", options.shard, " of ",
                options.num_shards, " does not exist");
  VLN_CHECK_ARG(options.num_shards == 1 || options.gather,
                "evaluateSplit(): ", options.num_shards,
                " shards need a gather over the processes");
  SplitEvaluation out;
  out.checkpoint = options.checkpoint;
  out.split = split.name;
  out.shard = options.shard;
  out.num_shards = options.num_shards;

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
  // every shard's episodes, so that what follows sees the whole split
  if (options.num_shards > 1) {
    const std::string mine = shardBytes(out.result);
    out.result = mergeShards(std::move(out.result), options.shard,
                             options.num_shards, options.gather(mine), split);
  }
  out.stats = out.result.stats;
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
  // FORMAT rxr) of every episode, scored or not
  if (!split.episodes.empty() &&
      std::all_of(split.episodes.begin(), split.episodes.end(),
                  [](const data::Episode& e) {
                    return e.instruction.instruction_id.has_value();
                  })) {
    std::vector<data::RxrPrediction> predictions;
    for (size_t i = 0; i < out.result.episodes.size(); ++i)
      predictions.push_back({*split.episodes[i].instruction.instruction_id,
                             data::rxrPathFromPositions(
                                 out.result.episodes[i].record.positions)});
    const fs::path file =
        options.out_dir / rxrPredictionsFileName(out.checkpoint, split.name);
    data::writeRxrPredictions(file, std::move(predictions));
    out.files.push_back(file);
  }
  return out;
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
  std::string share;
  if (evaluation.num_shards > 1)
    share = strCat(" (shard ", evaluation.shard, " of ", evaluation.num_shards,
                   "; the split has ", evaluation.result.episodes.size(), ")");
  std::snprintf(head, sizeof(head),
                "%d episodes%s, %lld steps in %.1f s (%.2f episodes/s, %.0f "
                "steps/s): ",
                evaluation.episodes, share.c_str(),
                static_cast<long long>(evaluation.steps), evaluation.seconds,
                evaluation.episodes / seconds,
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
