#pragma once
// The embedded RxR split (issue 17, "with no download"): RxR-like walks
// through the houses of the default world, annotated as RxR_VLNCE_v0 is,
// for the RxR-Habitat agent of configs/rxr/task.yaml.
//
// Per house (the world's houses, the same scenes and house roles):
//   1. rebuild the house (WorldGenerator.h buildWorldHouse()); its scene is
//      saved only when absent (it is then byte-identical to the default
//      world's, whose navmesh cache stays valid);
//   2. build the navmesh of the RxR agent (radius 0.18 m, height 0.88 m)
//      and save it as the scene's agent variant (sim::navMeshVariantFile(),
//      what the simulator loads for that agent), and as "<scene>.navmesh"
//      when there is none yet;
//   3. transfer the nav-graph's nodes to that navmesh (paper Section 3.2),
//      draw random walks of 8-14 nodes that may detour (RxrPathSampler.h)
//      and keep the navigable ones: reference path = the walk's waypoints,
//      ground truth = the follower's actions along them for the RxR agent
//      (forward 0.25 m, turn 30 degrees, no sliding; RxrFollower.h);
//   4. annotate every walk: guide_per_trajectory guide instructions and
//      follower_per_trajectory follower instructions (the follower walked
//      the guide's path: the same path and ground truth, its own
//      instruction and timing, edit_distance 0), each en-US or en-IN, with
//      per-word times aligned to the walk (RxrAnnotations.h).
// Written in the RxR_VLNCE_v0 layout (data/RxrEpisodes.h):
//
//   <out>/{split}/{split}_{role}.json.gz, <out>/{split}/{split}_{role}_gt
//   .json.gz for train, val_seen, val_unseen; test_challenge without goals,
//   reference paths or ground truth, which go to
//   <out>/hidden/test_challenge/test_challenge_{role}[_gt].json.gz;
//   <out>/connectivity/<house>_connectivity.json, <out>/generation_stats.json
//
// Instruction ids run over the whole dataset; episode ids are unique within
// a split across both roles. Byte-identical output for equal configs
// whatever the thread count; staged and published like the world.

#include <filesystem>
#include <map>
#include <ostream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "world/RxrWorldConfig.h"
#include "world/WorldGenerator.h"

namespace vln::world {

/// RxR's split names, in the order they are written and numbered.
const std::vector<std::string>& rxrSplitNames();

/// What was generated (the statistics are also generation_stats.json).
struct RxrWorldSummary {
  /// Episodes per split and role ("guide", "follower").
  std::map<std::string, std::map<std::string, int>> episodes;
  /// Walks per split.
  std::map<std::string, int> trajectories;
  /// The full statistics document.
  nlohmann::json stats;
};

/// Generates the RxR split of `config` into `output` (scenes under
/// output.scenes_dir, shared with the world of config.world). Throws
/// std::invalid_argument for an invalid config and std::runtime_error for
/// I/O failures or a split left empty (naming it); nothing is written then.
RxrWorldSummary generateRxrWorld(const RxrWorldConfig& config,
                                 const WorldOutput& output,
                                 std::ostream* log = nullptr);

}  // namespace vln::world
