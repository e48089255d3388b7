#pragma once
// How agents are evaluated (YAML section `eval:`), during training
// (early stopping on val_unseen SPL) and by the eval binary.

#include <string>
#include <vector>

#include "common/Config.h"

namespace vln::rollout {

struct EvalConfig {
  std::vector<std::string> splits = {"val_seen", "val_unseen"};
  std::string selection_split = "val_unseen";
  int episodes = -1;
  int train_eval_episodes = -1;
  int num_envs = 8;
  int threads = 2;
  bool sample_actions = false;
  std::string dtw = "exact";
  int seed = 0;
  bool save_episodes = true;
  int map_episodes = 3;
  int video_episodes = 0;
  int tensorboard_maps = 2;
  int tensorboard_videos = 0;

  void visit(common::ConfigVisitor& v) {
    v.field("splits", splits, "Splits evaluated by default");
    v.field("selection_split", selection_split,
            "Split whose SPL selects the best checkpoint (the paper's early "
            "stopping)");
    v.field("episodes", episodes,
            "Episodes per split (-1: all); N are spread evenly over the file "
            "(data::keepEvenlySpaced), so that they cover its scenes",
            common::atLeast(-1));
    v.field("train_eval_episodes", train_eval_episodes,
            "Episodes per split for the periodic evaluation during training "
            "(-1: same as episodes)",
            common::atLeast(-1));
    v.field("num_envs", num_envs,
            "Environments stepped together (the policy batch)",
            common::inRange(1, 1024));
    v.field("threads", threads,
            "Threads rendering and stepping the environments",
            common::inRange(1, 256));
    v.field("sample_actions", sample_actions,
            "Sample actions from the policy instead of taking the argmax");
    v.choice("dtw", dtw, {"exact", "fast"},
             "DTW used by nDTW: exact, or fast (FastDTW radius 1, as VLN-CE "
             "ran it)");
    v.field("seed", seed, "Seed for sampling and for the baselines",
            common::atLeast(0));
    v.field("save_episodes", save_episodes,
            "Write the per-episode file (paths, actions, metrics)");
    v.field("map_episodes", map_episodes,
            "Top-down map PNGs for the first N episodes of each split",
            common::atLeast(0));
    v.field("video_episodes", video_episodes,
            "Videos (RGB, depth, growing map) for the first N episodes of each "
            "split",
            common::atLeast(0));
    v.field("tensorboard_maps", tensorboard_maps,
            "Training: top-down maps (PNG) of the first N episodes of each "
            "split in TensorBoard at every periodic evaluation, tag "
            "eval/<split>/map/episode_<id> (needs output.tensorboard)",
            common::atLeast(0));
    v.field("tensorboard_videos", tensorboard_videos,
            "Training: videos (animated GIF: RGB, depth, growing map) of the "
            "first N episodes of each split in TensorBoard at every periodic "
            "evaluation, tag eval/<split>/video/episode_<id> (needs "
            "output.tensorboard)",
            common::atLeast(0));
  }
  bool operator==(const EvalConfig&) const = default;
};

}  // namespace vln::rollout
