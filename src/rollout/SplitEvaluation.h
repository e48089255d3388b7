#pragma once
// Evaluating one split: the environments, a progress line, the rollouts
// (evaluateEpisodes()), the stats and the files, and the summary line. The
// trainer's periodic validation and the eval binary both evaluate through
// evaluateSplit(), so the two write the same files in the same way.
//
// Files written into `out_dir` (Metrics.h has the formats):
//   stats_ckpt_<i>_<split>.json          means, when the split has goals
//   episodes_ckpt_<i>_<split>.json.gz    per-episode paths and metrics
//                                        (save_episodes)
//   predictions_ckpt_<i>_<split>.json    R2R leaderboard trajectories of
//                                        the episodes without goals (all
//                                        episodes with
//                                        predictions_of_scored)
//   rxr_predictions_ckpt_<i>_<split>.jsonl  RxR episodes (all with an
//                                        instruction_id): the RxR-Habitat
//                                        inference output of every episode
//                                        (data/RxrPredictions.h)
//
// A multi-process evaluation (the trainer's validation) shards the split
// over the processes and gathers every shard's episodes into each process,
// so the stats and files are those of one process running the whole split.

#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "data/Split.h"
#include "rollout/Agent.h"
#include "rollout/EvalConfig.h"
#include "rollout/Evaluator.h"
#include "rollout/Metrics.h"
#include "rollout/VectorEnv.h"
#include "sim/SimConfig.h"

namespace vln::rollout {

/// Exchanges byte strings among the processes of a multi-process run (an
/// all-gather): every process calls it with its own bytes and gets every
/// process's, its own included, in shard order.
using GatherOverProcesses =
    std::function<std::vector<std::string>(const std::string&)>;

/// How a split is evaluated and where its results go.
struct SplitEvaluationOptions {
  /// Index of the evaluated checkpoint, in file names and the summary line.
  int checkpoint = 0;
  /// What is evaluated, for the progress line ("evaluate <label> <split>");
  /// may be empty.
  std::string label;
  /// Where the files go; nothing is written when empty.
  std::filesystem::path out_dir;
  /// Also write the per-episode file.
  bool save_episodes = false;
  /// Also write the leaderboard predictions of scored episodes (a test
  /// split scored from its hidden goals keeps the file it had without them).
  bool predictions_of_scored = false;
  /// Watches the episodes (maps, videos); may be null.
  EpisodeObserver* observer = nullptr;
  /// Multi-process evaluation: this process runs episodes shard,
  /// shard + num_shards, ... of the split, and `gather` (required when
  /// num_shards > 1; called once per split by every process, whatever its
  /// share) hands it every shard's episodes, so that its result, stats and
  /// files are the whole split's, as one process's would be.
  int shard = 0;
  int num_shards = 1;
  GatherOverProcesses gather;
};

/// What one split's evaluation produced.
struct SplitEvaluation {
  int checkpoint = 0;
  std::string split;
  bool skipped =
      false;  ///< not run: its results existed (eval's directory mode)
  bool scored = false;  ///< episodes had goals (stats written)
  SplitStats stats;     ///< over the whole split (all processes)
  /// The whole split's episodes in its order; in a multi-process
  /// evaluation the other processes' records come without
  /// waypoint_choices (drawn while episodes run, never serialised).
  EvaluationResult result;
  int shard = 0;       ///< SplitEvaluationOptions::shard
  int num_shards = 1;  ///< SplitEvaluationOptions::num_shards
  int episodes = 0;    ///< episodes this process ran (its shard's)
  int64_t steps = 0;   ///< actions they took
  /// Wall time of this process's rollouts and metrics (not the gather).
  double seconds = 0.0;
  std::vector<std::filesystem::path> files;  ///< files written
};

/// Runs `agent` on `split` (eval.num_envs environments on eval.threads
/// threads, scenes from `scenes`) and writes the files of the file comment.
/// Throws what evaluateEpisodes() throws, and an exception naming the split
/// and the shard when gathered episodes are unreadable or do not fit the
/// split (the processes evaluated different splits).
SplitEvaluation evaluateSplit(Agent& agent, const data::Split& split,
                              const std::shared_ptr<SceneCache>& scenes,
                              const sim::SimConfig& sim,
                              const sim::TaskConfig& task,
                              const EvalConfig& eval,
                              const SplitEvaluationOptions& options);

/// "TL 7.12 NE 8.01 nDTW 0.412 OS 0.300 SR 0.250 SPL 0.231".
std::string metricsText(const EpisodeMetrics& metrics);

/// "ckpt 3 val_seen: 20 episodes, 1234 steps in 5.0 s (4.00 episodes/s,
/// 247 steps/s): TL ...", or "... skipped (already evaluated): TL ...",
/// or "...: no goals (leaderboard predictions written)". In a
/// multi-process evaluation the counts and rates are this process's
/// ("10 episodes (shard 1 of 2; the split has 20), ..."), the metrics the
/// whole split's.
std::string summaryLine(const SplitEvaluation& evaluation);

/// "predictions_ckpt_<checkpoint>_<split>.json".
std::string predictionsFileName(int checkpoint, std::string_view split);

/// "rxr_predictions_ckpt_<checkpoint>_<split>.jsonl".
std::string rxrPredictionsFileName(int checkpoint, std::string_view split);

}  // namespace vln::rollout
