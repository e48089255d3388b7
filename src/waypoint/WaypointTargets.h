#pragma once
// Training targets and ground truth of a candidate-waypoint predictor from a
// scene's nav-graph, as Hong et al. (CVPR 2022) build theirs from
// Matterport3D's connectivity, here on the world's graphs transferred onto
// the navmesh (data/NodeTransfer.h):
//
//  1. The agent stands on a transferred node with some heading. Each
//     neighbour (edge to a valid node) within the heatmap's range is a
//     target at its relative heading and horizontal distance; two in one
//     heading bin keep the farther.
//  2. Open space: along each of the 120 headings the agent walks 0.25 m
//     forward steps over the navmesh (sliding, collisions as in
//     sim/Agent.h) until a step collides, at most kNumDistances steps; the
//     horizontal distance reached is that heading's open distance. Cell
//     (h, d) is open when binDistance(d) <= open distance (rounded down to
//     whole steps), as their obstacle map counts it.
//  3. The heatmap: 1 at each target cell, smoothed by a Gaussian (sigma 1
//     heading bin, wrapping, and 2 distance bins, zero beyond the ends),
//     scaled to a peak of 1, then zeroed on cells that are not open
//     ("obstacle first"). A node whose remaining peak is below
//     min_peak_ratio is dropped: its targets lie behind obstacles.
//
// Heatmap layout and heading convention: waypoint/WaypointHeatmap.h.

#include <array>
#include <vector>

#include "common/Config.h"
#include "common/Math.h"
#include "data/NavGraph.h"
#include "data/NodeTransfer.h"
#include "sim/Agent.h"
#include "sim/NavMesh.h"
#include "sim/SimConfig.h"
#include "waypoint/WaypointHeatmap.h"

namespace vln::waypoint {

/// How targets are smoothed and which nodes are kept. Defaults are Hong et
/// al.'s (gen_training_data of their waypoint predictor).
struct WaypointTargetConfig {
  float sigma_heading = 1.0f;   ///< Gaussian sigma, heading bins
  float sigma_distance = 2.0f;  ///< Gaussian sigma, distance bins
  float min_peak_ratio = 0.75f;

  void visit(common::ConfigVisitor& v) {
    v.field("sigma_heading", sigma_heading,
            "Gaussian smoothing of the target heatmap across headings (bins)",
            common::inRange(0.1, 30.0));
    v.field("sigma_distance", sigma_distance,
            "Gaussian smoothing of the target heatmap across distances (bins)",
            common::inRange(0.1, 12.0));
    v.field("min_peak_ratio", min_peak_ratio,
            "Drop a node whose target peak left in open space is below this "
            "share of the peak",
            common::inRange(0.0, 1.0));
  }
  bool operator==(const WaypointTargetConfig&) const = default;
};

/// Open distance per heading bin (metres, horizontal): how far 0.25 m
/// forward steps (agent.forward_step_size) along heading bin h get before
/// the first collision, at most kNumDistances steps; index h. Throws what
/// sim::applyAction() throws for a position off the navmesh's bounds.
std::array<float, kNumHeadings> openDistances(const sim::NavMesh& navmesh,
                                              const sim::AgentConfig& agent,
                                              const sim::AgentState& state);

/// True when cell distance bin `d` lies within `openDistance` (step 2 of the
/// file comment: d < floor(openDistance / kDistanceStep + 1e-3)).
bool isOpen(float openDistance, int d);

/// One target waypoint.
struct TargetWaypoint {
  int node = -1;                   ///< graph index of the neighbour
  Vec3f position = Vec3f::Zero();  ///< transferred position (world)
  Polar polar;                     ///< relative to the agent
  int heading_bin = 0;
  int distance_bin = 0;
};

/// The targets of one node seen with one heading.
struct NodeTargets {
  sim::AgentState agent;                   ///< on the transferred node
  std::vector<TargetWaypoint> targets;     ///< one per heading bin
  std::array<float, kNumHeadings> open{};  ///< openDistances()
  std::vector<float> heatmap;              ///< [kHeatmapSize], step 3
  /// False when the node has no target in range or its peak falls below
  /// min_peak_ratio once masked (step 3).
  bool kept = false;
};

/// The targets of node `node` of `graph` for an agent standing on its
/// transferred position with `heading` (radians). `transferred` is
/// data::transferGraph()'s result for the graph; the node must be valid.
NodeTargets nodeTargets(
    const data::NavGraph& graph,
    const std::vector<data::NodeTransferResult>& transferred, int node,
    float heading, const sim::NavMesh& navmesh, const sim::AgentConfig& agent,
    const WaypointTargetConfig& config);

/// Step 3 alone: the smoothed, scaled and masked heatmap of target cells
/// (heading_bin, distance_bin) given the open distance per heading. Returns
/// kHeatmapSize values (all zero without targets).
std::vector<float> targetHeatmap(const std::vector<TargetWaypoint>& targets,
                                 const std::array<float, kNumHeadings>& open,
                                 const WaypointTargetConfig& config);

}  // namespace vln::waypoint
