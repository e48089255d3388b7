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
//   eval --config C --agent random|handcrafted       a no-learning baseline
//   eval tables --runs results/ --out docs/results.md
//
// Per evaluated (checkpoint i, split) the output directory receives (see
// Metrics.h and NavGraphEval.h for the formats):
//   stats_ckpt_<i>_<split>.json          means, when the split has goals
//   episodes_ckpt_<i>_<split>.json.gz    per-episode paths and metrics
//                                        (eval.save_episodes)
//   predictions_ckpt_<i>_<split>.json    R2R leaderboard trajectories, for
//                                        episodes without goals (test split)
//   navgraph_stats_ckpt_<i>_<split>.json with a nav-graph directory (Table 3;
//                                        see scoreOnNavGraph())
//   pictures/ckpt_<i>_<split>_episode_<id>_map.png and .avi/.mp4
//                                        (eval.map_episodes / video_episodes)
// and stdout one summary line per split.
//
// This module sits below train, so checkpoints are read through a
// CheckpointReader that the binary fills in from train/Checkpoint.h, and the
// run config arrives as the EvalSettings sections of train's
// ExperimentConfig.

#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <ostream>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "data/DatasetConfig.h"
#include "data/NavGraph.h"
#include "eval/NavGraphEval.h"
#include "models/ModelConfig.h"
#include "models/StateDict.h"
#include "rollout/EvalConfig.h"
#include "rollout/Metrics.h"
#include "sim/NavMesh.h"
#include "sim/SimConfig.h"

namespace vln::eval {

/// The sections of a run config that evaluation reads.
struct EvalSettings {
  sim::SimConfig sim;
  sim::TaskConfig task;
  data::DatasetConfig dataset;
  models::ModelConfig model;
  rollout::EvalConfig eval;
  /// trainer.torch_threads: LibTorch intra-op threads.
  int torch_threads = 2;
  /// trainer.seed: encoders without weight files (model.rgb_weights /
  /// depth_weights empty) are rebuilt with the trainer's seeded
  /// initialisation (manual_seed(seed), then the policy, then the encoders).
  int seed = 0;
  /// output.dir: results go to <output.dir>/eval unless --out is given.
  std::string output_dir = "runs/default";
};

/// How policy checkpoints are found and read (train/Checkpoint.h).
struct CheckpointReader {
  /// The ckpt.<i>.pth files of a directory by increasing index.
  std::function<std::vector<std::filesystem::path>(const std::filesystem::path&)>
      list;
  /// The index of a checkpoint file name, nullopt when it is not one.
  std::function<std::optional<int>(const std::filesystem::path&)> index;
  /// The policy tensors of a checkpoint file.
  std::function<models::NamedTensors(const std::filesystem::path&)> policy;
};

/// Options of the evaluation command.
struct EvalCommandOptions {
  /// A checkpoint file, a directory of checkpoints, or a TorchScript export
  /// (.pt). Empty when `agent` is set.
  std::filesystem::path checkpoint;
  /// "random" or "handcrafted": evaluate a baseline instead (its statistics
  /// come from dataset.train_split's ground truth).
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
  /// Index used in file names for an export or a baseline; unset: parsed
  /// from the file name (ckpt.<i>.*), else 0.
  std::optional<int> index;
};

/// What one (checkpoint, split) evaluation produced.
struct SplitReport {
  int checkpoint = 0;
  std::string split;
  bool skipped = false;  ///< its stats file existed (directory mode)
  bool scored = false;   ///< the split had goals (stats written)
  rollout::SplitStats stats;
  std::optional<GraphSplitStats> graph;
  int episodes = 0;
  int64_t steps = 0;     ///< actions taken over all episodes
  double seconds = 0.0;  ///< wall time of the rollouts and metrics
  std::vector<std::filesystem::path> files;  ///< files written
};

/// Everything the command did.
struct EvalCommandResult {
  std::vector<SplitReport> reports;
  /// Directory mode: best checkpoint by eval.selection_split SPL (ties: the
  /// earliest), when any has stats for that split.
  std::optional<int> best_checkpoint;
  double best_spl = -1.0;
};

/// Runs the evaluation described by `options` with `settings`; prints one
/// summary line per split (and the best checkpoint) to `out`. Throws
/// std::invalid_argument / std::runtime_error naming the file, option or
/// field on bad input (a policy whose tensors do not match model.* lists
/// every mismatched tensor).
EvalCommandResult runEvaluation(const EvalCommandOptions& options,
                                const EvalSettings& settings,
                                const CheckpointReader& reader,
                                std::ostream& out);

/// runEvaluation(); returns the exit code.
int runEvalCommand(const EvalCommandOptions& options,
                   const EvalSettings& settings, const CheckpointReader& reader,
                   std::ostream& out);

/// "predictions_ckpt_<checkpoint>_<split>.json".
std::string predictionsFileName(int checkpoint, std::string_view split);

/// The summary line of one split ("ckpt 3 val_seen: 20 episodes ...").
std::string summaryLine(const SplitReport& report);

/// A copy of `graph` (same ids, order and edges) whose nodes are moved to
/// their Section 3.2 waypoints on `navmesh` (data::transferGraph() with the
/// paper's TransferConfig); nodes that do not transfer keep their position.
/// Connectivity files hold R2R viewpoints at camera height (1.2-1.6 m above
/// the floor), while agent positions and R2R_VLNCE reference paths are on
/// the floor, so the agent's path is matched against this copy.
data::NavGraph floorNavGraph(const data::NavGraph& graph,
                             const sim::NavMesh& navmesh);

/// The supplement's conversion of one continuous episode: start and goal
/// nodes from the reference path and the agent's path snapped node by node,
/// both on `floorGraph` (floorNavGraph() of `graph`), then scored with R2R's
/// eval.py on `graph` itself (the viewpoints' own geometry, as the VLN
/// leaderboard scores them).
GraphEpisodeMetrics scoreOnNavGraph(const data::NavGraph& graph,
                                    const data::NavGraph& floorGraph,
                                    std::span<const Vec3f> positions,
                                    std::span<const Vec3f> referencePath,
                                    std::string_view episodeId);

/// Options of `eval tables`.
struct TablesCommandOptions {
  std::filesystem::path runs;  ///< results directory (Tables.h layout)
  std::filesystem::path out;   ///< Markdown file; the LaTeX goes beside it (.tex)
};

/// Builds Tables 1-3 from `runs` (eval::buildTables()) and writes Markdown
/// to `out` and LaTeX to `out` with the extension .tex; prints both paths.
/// Returns the exit code.
int runTablesCommand(const TablesCommandOptions& options, std::ostream& out);

}  // namespace vln::eval
