#pragma once
// The trainer's validation (trainer.eval_during_training): the policy in
// memory, evaluated as checkpoint i on eval.splits (eval.train_eval_episodes
// each, else eval.episodes) through rollout::evaluateSplit(), writing
// <output.dir>/eval/stats_ckpt_<i>_<split>.json (and for a split of RxR
// episodes rxr_predictions_ckpt_<i>_<split>.jsonl) as the eval binary does,
// a summary line per split in the log and an "eval" record in the metrics.
// No per-episode file (eval.save_episodes is the eval binary's).
//
// TensorBoard media (output.tensorboard, docs/paper_scale.md): the top-down
// maps of the first eval.tensorboard_maps episodes of each split and videos
// (animated GIFs) of the first eval.tensorboard_videos, drawn by
// viz::EpisodeMedia while the episodes run, as image summaries
// eval/<split>/map/episode_<id> and eval/<split>/video/episode_<id> at
// step = the checkpoint index, and an "eval_media" record listing them in
// the metrics. With both counts 0 (or TensorBoard off) no observer runs.
//
// In a multi-process run rank r evaluates episodes r, r + N, ... of each
// split and the ranks gather each other's episodes (SplitEvaluation.h), so
// every rank holds the whole split's episodes and stats (computed as one
// process computes them), and rank 0 writes the whole split's files. The
// media are rank 0's alone: they show the first episodes of its own share
// (episodes 0, N, 2N, ... of the split). Each rank logs its own summary
// line (its share's counts, the split's metrics).

#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <vector>

#include "data/Split.h"
#include "models/ObservationEncoder.h"
#include "models/Policy.h"
#include "rollout/Agent.h"
#include "rollout/VectorEnv.h"
#include "train/ExperimentConfig.h"
#include "train/MetricsLog.h"

namespace vln::train {

class CheckpointKeeper;
class Distributed;
struct TrainingProgress;

class PeriodicEvaluator {
 public:
  /// Loads the splits. Throws std::invalid_argument naming a split without
  /// goals (there is nothing to validate on). `dist` may be null.
  PeriodicEvaluator(const ExperimentConfig& config,
                    std::shared_ptr<rollout::SceneCache> scenes,
                    Distributed* dist);

  /// Evaluates `policy` (left in train mode afterwards) with `encoder` as
  /// checkpoint `index`, saved after `updates` optimizer updates; `metrics`
  /// (may be null) receives the records ("eval": the split's means,
  /// "checkpoint", "updates", "split", "num_episodes").
  /// Returns eval.selection_split's SPL (-1 when it is not evaluated).
  double evaluate(int index, int64_t updates,
                  const std::shared_ptr<models::PolicyImpl>& policy,
                  const models::ObservationEncoder& encoder,
                  MetricsLog* metrics);

  /// The agent evaluate() runs on `split` (built per split: an rxr_text
  /// policy reads that split's text features).
  using AgentForSplit =
      std::function<std::unique_ptr<rollout::Agent>(const data::Split&)>;
  /// evaluate() of any agent (the waypoint agent's trainer); the caller
  /// restores its modules' training mode.
  double evaluateAgent(int index, int64_t updates,
                       const AgentForSplit& agentFor, MetricsLog* metrics);
  /// When every split's stats file of checkpoint `index` exists (rank 0's
  /// eval/ directory decides for all ranks): the selection split's SPL in
  /// them (-1 when it is not evaluated). nullopt otherwise.
  std::optional<double> recorded(int index);

  /// Evaluates the policy as checkpoint progress.checkpoint_index (see
  /// evaluate()) and records its selection SPL with `keeper`; true when
  /// training should stop (the keeper's patience is exhausted).
  bool evaluateLatest(TrainingProgress& progress, CheckpointKeeper& keeper,
                      int64_t updates,
                      const std::shared_ptr<models::PolicyImpl>& policy,
                      const models::ObservationEncoder& encoder,
                      MetricsLog* metrics);

  /// After a resume: the evaluation due after the last checkpoint
  /// (progress.extra "eval_due") that did not finish before the
  /// interruption is folded in from its files when they are complete, run
  /// otherwise. False when none was due; else as evaluateLatest().
  bool catchUp(TrainingProgress& progress, CheckpointKeeper& keeper,
               int64_t updates,
               const std::shared_ptr<models::PolicyImpl>& policy,
               const models::ObservationEncoder& encoder, MetricsLog* metrics);

 private:
  ExperimentConfig config_;
  std::filesystem::path dir_;
  std::shared_ptr<rollout::SceneCache> scenes_;
  Distributed* dist_;
  std::vector<data::Split> splits_;
};

}  // namespace vln::train
