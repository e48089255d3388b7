#pragma once
// How agents are evaluated (YAML section `eval:`), during training
// (early stopping on val_unseen SPL) and by the eval binary.

#include <string>
#include <vector>

#include "common/Config.h"

namespace vln::rollout {

struct EvalConfig {
  /// Splits evaluated by default.
  std::vector<std::string> splits = {"val_seen", "val_unseen"};
  /// Split whose SPL selects the best checkpoint (the paper's early stopping).
  std::string selection_split = "val_unseen";
  /// Episodes per split (-1: all). Deterministic: N spread evenly over the
  /// file (data::keepEvenlySpaced), so that they cover its scenes.
  int episodes = -1;
  /// Episodes per split for the periodic evaluation during training
  /// (-1: same as `episodes`).
  int train_eval_episodes = -1;
  /// Environments stepped together (the policy batch).
  int num_envs = 8;
  /// Threads rendering/stepping the environments.
  int threads = 2;
  /// Sample actions from the policy instead of taking the argmax.
  bool sample_actions = false;
  /// DTW for nDTW: exact, or fast (FastDTW radius 1, as VLN-CE ran it).
  std::string dtw = "exact";
  /// Seed for sampling and for the baselines.
  int seed = 0;
  /// Write the per-episode file (paths, actions, metrics).
  bool save_episodes = true;
  /// Top-down map PNGs for the first N episodes of each split.
  int map_episodes = 3;
  /// Videos (RGB, depth, growing map) for the first N episodes of each split.
  int video_episodes = 0;

  void visit(common::ConfigVisitor& v) {
    v.field("splits", splits, "Splits evaluated by default");
    v.field("selection_split", selection_split,
            "Split whose SPL picks the best checkpoint");
    v.field("episodes", episodes, "Episodes per split (-1: all)",
            common::atLeast(-1));
    v.field("train_eval_episodes", train_eval_episodes,
            "Episodes per split during training (-1: as episodes)",
            common::atLeast(-1));
    v.field("num_envs", num_envs, "Environments stepped together",
            common::inRange(1, 1024));
    v.field("threads", threads, "Environment threads", common::inRange(1, 256));
    v.field("sample_actions", sample_actions,
            "Sample actions instead of argmax");
    v.choice("dtw", dtw, {"exact", "fast"}, "DTW used by nDTW");
    v.field("seed", seed, "Seed for sampling and baselines",
            common::atLeast(0));
    v.field("save_episodes", save_episodes, "Write the per-episode file");
    v.field("map_episodes", map_episodes, "Top-down maps per split",
            common::atLeast(0));
    v.field("video_episodes", video_episodes, "Videos per split",
            common::atLeast(0));
  }
  bool operator==(const EvalConfig&) const = default;
};

}  // namespace vln::rollout
