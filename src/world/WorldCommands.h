#pragma once
// The world subcommands of vlnce-data as plain functions over parsed
// options (the binary stays a thin CLI11 layer; tests call these directly).
// Each returns the process exit code and writes its report to `out`.

#include <cstdint>
#include <filesystem>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "world/RxrWorldConfig.h"
#include "world/WorldConfig.h"

namespace vln::world {

/// `vlnce-data generate`.
struct GenerateCommandOptions {
  std::filesystem::path out;  ///< dataset root
  std::filesystem::path
      config;  ///< WorldConfig YAML; empty = built-in defaults
  std::filesystem::path scenes_dir = "data/scene_datasets";
  std::optional<int> houses;    ///< overrides config `houses`
  std::optional<int64_t> seed;  ///< overrides config `seed`
  int threads = 1;              ///< houses processed in parallel
  /// "section.key=value" overrides applied after the YAML file.
  std::vector<std::string> overrides;
};

/// Loads the world config of `options` (file, overrides, --houses, --seed),
/// validated.
WorldConfig loadWorldConfig(const GenerateCommandOptions& options);

/// True when `file` is an RxR split config (RxrWorldConfig.h): a YAML file
/// with a top-level `world:` key, which a WorldConfig never has.
bool isRxrWorldConfigFile(const std::filesystem::path& file);

/// Loads the RxR split config of `options` (file, overrides; --houses sets
/// world.houses, --seed both seed and world.seed), validated.
RxrWorldConfig loadRxrWorldConfig(const GenerateCommandOptions& options);

/// Generates the procedural world (see WorldGenerator.h), or its RxR split
/// when the config is an RxR one (RxrWorldGenerator.h), and prints what it
/// made and the paper's transfer statistics.
int runGenerateCommand(const GenerateCommandOptions& options,
                       std::ostream& out);

/// `vlnce-data transfer`.
struct TransferCommandOptions {
  std::filesystem::path graph;  ///< nav-graph JSON (NavGraph.h layout)
  std::filesystem::path scene;  ///< scene mesh (.glb, .obj, .ply, ...)
  std::filesystem::path out;    ///< optional: transferred graph + stats JSON
  /// Optional WorldConfig YAML: its navmesh, agent, trajectories and
  /// transfer sections are used.
  std::filesystem::path config;
  std::vector<std::string> overrides;  ///< "section.key=value"
  std::string up_axis = "y";           ///< up axis of the scene file: y or z
  int trajectories = 500;  ///< sampled R2R-like trajectories to check
  int64_t seed = 1;        ///< trajectory sampling and start headings
  bool json = false;       ///< print only the statistics, as JSON
};

/// Runs the Section 3.2 transfer of every node of a nav-graph onto the
/// scene's navmesh and the navigability check of up to `trajectories`
/// R2R-like trajectories sampled on the graph; prints the paper's
/// statistics. With `out`, writes {"nodes": transferred waypoints of the
/// valid nodes, "edges": edges between valid nodes, "rejected": ids,
/// "displacement": {id: metres}, "stats": {...}}, which reads back as a
/// NavGraph of waypoints.
int runTransferCommand(const TransferCommandOptions& options,
                       std::ostream& out);

}  // namespace vln::world
