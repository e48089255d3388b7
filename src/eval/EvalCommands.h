#pragma once
// The `eval` binary as plain functions over parsed options (apps/EvalMain.cpp
// stays a thin CLI11 layer; tests call these directly).
//
//   eval --config C --checkpoint ckpt.<i>.pth       one checkpoint
//   eval --config C --checkpoint DIR                 every ckpt.<i>.pth of DIR
//                                                     in order, skipping those
//                                                     already evaluated; picks
//                                                     the best (best.json)
//   eval --config C --checkpoint policy.pt           a TorchScript export
//   eval --config C --checkpoint ckpt.<i>.pth --ensemble RUN_OR_CKPT ...
//                                                     a waypoint agent whose
//                                                     choice averages the
//                                                     probabilities of the
//                                                     checkpoint's policy and
//                                                     the members' (other
//                                                     seeds of the recipe)
//   eval --config C --agent random|handcrafted       a no-learning baseline
//   eval --config C --agent oracle                   the shortest-path oracle
//                                                     (trainer.expert)
//   eval ... --dump DIR [--dump-episodes N | --dump-ids a,b]
//            [--dump-format png|jpg]                 observation dumps
//                                                     (DumpOptions.h)
//   eval ... --split test --test-ground-truth H      scores the test split
//                                                     from its hidden goals
//                                                     (<data>/hidden)
//   eval tables --runs results/ --out docs/results.md [--claimed-only]
//   eval curve --run runs/main/cma --out curve.png   the run's learning
//                                                     curve (validations in
//                                                     metrics.jsonl)
//   eval compare --runs results/ --out findings.md   the paper's findings
//                                                     judged by paired
//                                                     differences over seeds
//
// Per evaluated (checkpoint i, split) the output directory receives the
// files of rollout::evaluateSplit() (stats, per-episode file with
// eval.save_episodes, leaderboard predictions for a split without goals),
// and:
//   navgraph_stats_ckpt_<i>_<split>.json with a nav-graph directory (Table 3;
//                                        see scoreOnNavGraph())
//   pictures/ckpt_<i>_<split>_episode_<id>_map.png and .avi/.mp4
//                                        (eval.map_episodes / video_episodes)
// and stdout one summary line per split. Checkpoints are the trainer's
// (train/Checkpoint.h), read with the run config's model.

#include <filesystem>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "eval/DumpOptions.h"
#include "eval/NavGraphEval.h"
#include "rollout/SplitEvaluation.h"
#include "train/ExperimentConfig.h"

namespace vln::eval {

/// Options of the evaluation command.
struct EvalCommandOptions {
  /// A checkpoint file, a directory of checkpoints, or a TorchScript export
  /// (.pt). Empty when `agent` is set.
  std::filesystem::path checkpoint;
  /// With `checkpoint` a checkpoint file of a waypoint agent (trainer.task
  /// waypoint_cma): more policies of the same recipe (other seeds) that
  /// vote with it, each a checkpoint file or a run directory (its best
  /// checkpoint, else its newest; train::readPolicyWeights()). Their choice
  /// probabilities are averaged (rollout::ensembleLogits()).
  std::vector<std::filesystem::path> ensemble;
  /// "random" or "handcrafted": evaluate a baseline instead (its statistics
  /// come from dataset.train_split's ground truth); "oracle": the
  /// shortest-path oracle of trainer.expert (rollout::OracleAgent; splits
  /// without goals are refused).
  std::string agent;
  /// Splits to evaluate; empty: eval.splits.
  std::vector<std::string> splits;
  /// Episodes per split (N spread evenly over the file); unset: eval.episodes.
  std::optional<int> episodes;
  /// Output directory; empty: <output.dir>/eval.
  std::filesystem::path out;
  /// Directory of <scan>_connectivity.json nav-graphs; empty: no nav-graph
  /// comparison.
  std::filesystem::path navgraph;
  /// Maps / videos per split; unset: eval.map_episodes / video_episodes.
  std::optional<int> maps;
  std::optional<int> videos;
  /// Video container: "avi" (MJPG) or "mp4" (mp4v).
  std::string video_format = "avi";
  /// HTML report folder (viz/EpisodeReport.h): one page per evaluation in
  /// <report>/<ckpt_<i> or agent>_<split>/ and an index of them; empty: no
  /// report.
  std::filesystem::path report;
  /// Episodes per report with a map, frames and attention.
  int report_episodes = 5;
  /// Index used in file names for an export or a baseline; unset: parsed
  /// from the file name (ckpt.<i>.*), else 0.
  std::optional<int> index;
  /// Observation dumps of the evaluated episodes (--dump ...).
  DumpOptions dump;
  /// The test split's hidden goals and ground truth (data/Split.h: either
  /// file, hidden/test/, hidden/ or the dataset root): the split "test" is
  /// then scored (stats file) and still gets its leaderboard predictions.
  /// RxR datasets: the split "test_challenge", from the RxR files under
  /// hidden/test_challenge/ (data::attachHiddenRxrGoals()).
  /// Empty: the test split is run without goals, predictions only.
  std::filesystem::path test_ground_truth;
};

/// What one (checkpoint, split) evaluation produced.
struct SplitReport : rollout::SplitEvaluation {
  std::optional<GraphSplitStats> graph;  ///< with a nav-graph directory
};

/// Everything the command did.
struct EvalCommandResult {
  std::vector<SplitReport> reports;
  /// Directory mode: best checkpoint by eval.selection_split SPL (ties: the
  /// earliest), when any has stats for that split.
  std::optional<int> best_checkpoint;
  double best_spl = -1.0;
};

/// Runs the evaluation described by `options` with the run config
/// `config` (its sim, task, dataset, model and eval sections,
/// trainer.torch_threads, trainer.seed and output.dir); prints one summary
/// line per split (and the best checkpoint) to `out`. Throws
/// std::invalid_argument / std::runtime_error naming the file, option or
/// field on bad input (a policy whose tensors do not match model.* lists
/// every mismatched tensor).
EvalCommandResult runEvaluation(const EvalCommandOptions& options,
                                const train::ExperimentConfig& config,
                                std::ostream& out);

/// runEvaluation(); returns the exit code.
int runEvalCommand(const EvalCommandOptions& options,
                   const train::ExperimentConfig& config, std::ostream& out);

/// The summary line of one split (rollout::summaryLine(), then the
/// nav-graph metrics when there are any).
std::string summaryLine(const SplitReport& report);

/// Options of `eval tables`.
struct TablesCommandOptions {
  std::filesystem::path runs;  ///< results directory (Tables.h layout)
  std::filesystem::path
      out;  ///< Markdown file; the LaTeX goes beside it (.tex)
  /// only the rows some run claims (eval::claimedRowsOnly()), for a job
  /// that ran a few rows rather than the whole reproduction
  bool claimed_only = false;
};

/// Builds Tables 1-3 from `runs` (eval::buildTables()) and writes Markdown
/// to `out` and LaTeX to `out` with the extension .tex; prints both paths.
/// Returns the exit code.
int runTablesCommand(const TablesCommandOptions& options, std::ostream& out);

/// Options of `eval compare`.
struct CompareCommandOptions {
  std::filesystem::path runs;  ///< results directory (Tables.h layout)
  std::filesystem::path out;   ///< Markdown file
};

/// Options of `eval curve`.
struct CurveCommandOptions {
  std::filesystem::path run;  ///< a training run's output.dir (metrics.jsonl)
  std::filesystem::path out;  ///< PNG file
  std::string split = "val_unseen";  ///< the validated split drawn
  std::string title;  ///< empty: "<split> learning curve: <run folder>"
};

/// Draws the learning curve of the run (viz/LearningCurve.h: SR and SPL of
/// `split` against wall time and updates) into `out`; prints the path, the
/// number of validations and the best by SPL. Returns the exit code.
int runCurveCommand(const CurveCommandOptions& options, std::ostream& out);

/// Judges the paper's findings (eval::paperFindings()) by paired
/// differences over the seeds of the runs under `runs`, on kFindingSplit
/// and kFindingMetrics, and writes the Markdown to `out`; prints the path
/// and the count of each verdict. Returns the exit code.
int runCompareCommand(const CompareCommandOptions& options, std::ostream& out);

}  // namespace vln::eval
