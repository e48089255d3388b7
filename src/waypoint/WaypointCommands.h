#pragma once
// `vlnce-data waypoint-metrics`: the candidate-waypoint predictor metrics
// (WaypointMetrics.h) of the geometry-only baseline (DepthWaypointBaseline.h)
// on the houses of one split, against nav-graph targets
// (WaypointTargets.h), beside the targets themselves snapped to their cells
// (the floor that the heatmap's quantisation leaves).

#include <cstdint>
#include <filesystem>
#include <ostream>
#include <string>

#include "sim/Panorama.h"
#include "sim/SimConfig.h"
#include "waypoint/DepthWaypointBaseline.h"
#include "waypoint/WaypointTargets.h"

namespace vln::waypoint {

struct WaypointMetricsOptions {
  /// R2R_VLNCE dataset root: <root>/<split>/<split>.json.gz names the
  /// houses, <root>/connectivity/<house>_connectivity.json their graphs.
  std::filesystem::path dataset = "data/datasets/procedural";
  std::filesystem::path scenes_dir = "data/scene_datasets";
  std::string split = "val_unseen";
  int max_nodes = -1;         ///< nodes per house, evenly spaced; -1: all
  int64_t seed = 1;           ///< the agent's heading on each node
  int threads = 2;            ///< houses scored in parallel
  std::filesystem::path out;  ///< optional JSON report
  bool json = false;          ///< print the JSON report instead of text
  sim::SimConfig sim;         ///< navmesh, agent, renderer
  sim::PanoramaConfig panorama;
  WaypointTargetConfig targets;
  DepthBaselineConfig baseline;
};

/// Scores the split's houses and prints (or writes) the report; returns the
/// exit code. Throws std::invalid_argument naming the option when one is
/// out of range, and what reading the files throws, naming them.
int runWaypointMetricsCommand(const WaypointMetricsOptions& options,
                              std::ostream& out);

}  // namespace vln::waypoint
