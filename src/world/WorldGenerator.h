#pragma once
// The embedded default world: procedural houses turned into an R2R_VLNCE
// dataset by the paper's own pipeline, so that training and evaluation run
// with no download.
//
// Per house (houses are independent and run on a thread pool):
//   1. generate the house and place an R2R-style nav-graph of panoramas in
//      it as captured (NavGraphBuilder.h);
//   2. make the reconstruction differ as real scans do (doors closed and
//      objects moved between captures, CaptureDifferences.h) and save that
//      as the scene (.glb, semantics sidecar, .glb.navmesh) under
//      <scenes_dir>/<scene_prefix>/<house>/;
//   3. transfer the nodes to its navmesh (NodeTransfer.h, paper Section 3.2);
//   4. sample R2R-like trajectories on the graph (TrajectorySampler.h), keep
//      the navigable ones with their ground-truth follower actions, and give
//      each generated instructions (InstructionGenerator.h).
// Then, in house order: the splits of R2R (train and val_seen in train
// houses, val_unseen and test in held-out houses, train_aug with
// speaker-style instructions in train houses), the instruction vocabulary of
// the training corpus, GloVe vectors fitted on it, the nav-graphs and the
// statistics, all written in the public R2R_VLNCE layout:
//
//   <out>/<split>/<split>.json.gz, <out>/<split>/<split>_gt.json.gz (none
//   for test, as in the real release), <out>/embeddings.json.gz,
//   <out>/connectivity/<house>_connectivity.json, <out>/generation_stats.json
//
// The test split's goals and ground truth go to a separate hidden folder
// (data/Split.h), the local leaderboard that only `eval
// --test-ground-truth` reads and the trainer never does:
//
//   <out>/hidden/test/test_goals.json.gz  test's episodes with goals, info
//                                         and reference_path
//   <out>/hidden/test/test_gt.json.gz     test's ground truth
//
// Output is byte-identical for equal configs whatever the thread count.
// Every output is staged in a temporary directory and renamed into place,
// one whole split directory at a time, only after everything succeeded: a
// failure never leaves a half-written split.

#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <ostream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "data/NodeTransfer.h"
#include "world/CaptureDifferences.h"
#include "world/HouseGenerator.h"
#include "world/NavGraphBuilder.h"
#include "world/WorldConfig.h"

namespace vln::world {

/// The split names, in the order they are listed and numbered.
const std::vector<std::string>& worldSplitNames();

/// Where the world goes.
struct WorldOutput {
  std::filesystem::path out;         ///< dataset root (<out>/<split>/...)
  std::filesystem::path scenes_dir;  ///< scene ids are relative to this
  int threads = 1;                   ///< houses processed in parallel
};

/// What was generated (also written as generation_stats.json).
struct WorldSummary {
  data::TransferStats transfer;  ///< all houses
  /// Episodes per split.
  std::map<std::string, int> episodes;
  /// Distinct trajectories per split.
  std::map<std::string, int> trajectories;
  /// House names per role ("train", "val_unseen", "test").
  std::map<std::string, std::vector<std::string>> houses;
  int vocabulary_size = 0;
  /// The full statistics document.
  nlohmann::json stats;
};

/// The name of house `index` of a world: "house_<index>_<8 hex digits>",
/// the digits hashing the house seed and the house and navmesh configs, so
/// different worlds never overwrite each other's scenes.
std::string worldHouseName(const WorldConfig& config, int index);

/// The first house index of splits.extra_unseen_houses: above any index
/// `houses` + splits.extra_train_houses can reach, so that a held-out house
/// is never a train house of the same seed in another world version.
inline constexpr int kExtraUnseenFirstIndex = 1000000;

/// The role of every house slot of a world: "train", "val_unseen" or
/// "test" for the first `houses`, "train_extra" for the
/// splits.extra_train_houses after them, then "val_unseen_extra" for the
/// splits.extra_unseen_houses. Throws std::invalid_argument when no train
/// house is left.
std::vector<std::string> worldHouseRoles(const WorldConfig& config);

/// The house index (worldHouseName(), the house seed) of house slot `slot`
/// of worldHouseRoles(): the slot itself, except for the extra unseen
/// houses, numbered from kExtraUnseenFirstIndex.
int worldHouseIndex(const WorldConfig& config, int slot);

/// House `index` of a world as its scene is saved (steps 1 and 2 of the
/// file comment, before the navmesh): the reconstructed house, the nav-graph
/// of the captured one and what the reconstruction changed.
struct WorldHouse {
  std::string name;      ///< worldHouseName()
  std::string scene_id;  ///< <scene_prefix>/<name>/<name>.glb
  uint64_t seed = 0;     ///< the house's seed, every stage derives from it
  House house;           ///< as reconstructed (the scene agents move in)
  BuiltNavGraph built;   ///< placed in the house as captured
  CaptureDifferences differences;
};

/// Builds house `index` of the world `config`; deterministic.
WorldHouse buildWorldHouse(const WorldConfig& config, int index);

/// Runs process(i) for every house index i in [0, houses) on `threads`
/// threads (this one included), with a progress line labelled `label`.
/// After the first failure no further house starts; the first failure in
/// house order is rethrown with `caller` and the house's name
/// (worldHouseName(config, i)) in front of its message, its type (bad
/// input: std::invalid_argument, else std::runtime_error) kept.
void forEachWorldHouse(const WorldConfig& config, int houses, int threads,
                       const char* label, const char* caller,
                       const std::function<void(int)>& process);

/// Moves every entry of `staging` into `out` (created beforehand),
/// replacing what was there; the replaced entries go to `trash` first and
/// are removed at the end, as are `staging` and `trash`. Throws
/// std::runtime_error naming the entry when a rename fails.
void publishStaged(const std::filesystem::path& staging,
                   const std::filesystem::path& out,
                   const std::filesystem::path& trash);

/// Generates the world described by `config` into `output`, logging
/// progress through spdlog and the paper's statistics to `log` when given.
/// Throws std::invalid_argument for an invalid config and
/// std::runtime_error for I/O failures or a world too small to fill a split
/// (naming the split); in both cases no split is written.
WorldSummary generateWorld(const WorldConfig& config, const WorldOutput& output,
                           std::ostream* log = nullptr);

}  // namespace vln::world
