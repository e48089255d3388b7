#pragma once
// Section 3.2 of the VLN-CE paper: transferring nav-graph trajectories to a
// continuous scene.
//
//  1. Node transfer. A panorama node sits at camera height, sometimes over
//     furniture or a hole in the reconstruction. A ray is cast straight down
//     from it for up to 2 m; at fixed small intervals along that ray the
//     sample is projected to the nearest navmesh point (a small search box);
//     among the projections that land on a floor a ground agent can use, the
//     one with the least horizontal displacement wins, and the node is
//     invalid when none is within 0.5 m. Furniture tops form small navmesh
//     islands of their own; they are not floors.
//  2. Navigability. Between consecutive waypoints the navmesh (A*) shortest
//     path must exist, and an agent that follows it with the 0.5 m
//     shortest-path follower must get within 0.5 m of the next waypoint. The
//     follower's actions over the whole trajectory (STOP once at the end) are
//     the episode's ground truth, recorded as VLN-CE records them.
//
// All positions are world frame (+Y up, metres); waypoints are at the
// agent's feet on the navmesh, nodes at camera height.

#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "common/Math.h"
#include "data/GroundTruth.h"
#include "data/NavGraph.h"
#include "data/TransferConfig.h"
#include "sim/Agent.h"
#include "sim/NavMesh.h"

namespace vln::data {

/// Islands of `navmesh` a ground agent may stand on: island 0 (the largest)
/// and every island of at least `minArea` m^2. Indexed by island.
std::vector<bool> floorIslands(const sim::NavMesh& navmesh, float minArea);

/// Where one nav-graph node lands.
struct NodeTransferResult {
  bool valid = false;
  /// The waypoint: a navmesh point on a floor island (valid nodes only).
  Vec3f waypoint = Vec3f::Zero();
  /// Horizontal distance from the node to the waypoint, metres.
  float displacement = 0.0f;
  int island = -1;  ///< navmesh island of the waypoint, -1 when invalid
  bool operator==(const NodeTransferResult&) const = default;
};

/// Transfers one node at camera height `node` (world frame) as in step 1 of
/// the file comment. `floors` comes from floorIslands().
NodeTransferResult transferNode(const sim::NavMesh& navmesh, const Vec3f& node,
                                const TransferConfig& config,
                                const std::vector<bool>& floors);

/// Transfers every node of `graph`; entry i belongs to graph.node(i).
std::vector<NodeTransferResult> transferGraph(const NavGraph& graph,
                                              const sim::NavMesh& navmesh,
                                              const TransferConfig& config);

/// Why a trajectory is not navigable.
enum class NavigabilityFailure {
  kNone,         ///< navigable
  kInvalidNode,  ///< a node could not be transferred
  kNoPath,       ///< no navmesh path between two consecutive waypoints
  kNotReached,   ///< the follower did not get within the radius in time
  kDetour,       ///< a leg's geodesic exceeds max_leg_detour (not in the paper)
};

/// "none", "invalid_node", "no_path", "not_reached", "detour".
std::string navigabilityFailureName(NavigabilityFailure failure);

/// Outcome of the navigability check of one trajectory.
struct NavigabilityResult {
  NavigabilityFailure failure = NavigabilityFailure::kNone;
  /// Leg i (waypoint i to i+1) that failed, or the index of the invalid
  /// node; -1 when navigable.
  int failed_index = -1;
  /// The follower's actions (ending with one STOP), the start position
  /// followed by every position the agent moved to, and the number of
  /// MOVE_FORWARD actions. Filled only when navigable.
  GroundTruthPath ground_truth;
  /// Navmesh geodesic distance from the first to the last waypoint, metres.
  float geodesic_distance = 0.0f;

  bool navigable() const { return failure == NavigabilityFailure::kNone; }
};

/// Step 2 of the file comment for transferred `waypoints` (at least two, on
/// the navmesh), starting at waypoints[0] with `startHeading` radians.
NavigabilityResult checkNavigability(const sim::NavMesh& navmesh,
                                     const sim::AgentConfig& agent,
                                     const TransferConfig& config,
                                     const std::vector<Vec3f>& waypoints,
                                     float startHeading);

/// Same for a trajectory of graph node indices with the transfer results of
/// its graph: fails with kInvalidNode at the first invalid node.
NavigabilityResult checkNavigability(
    const sim::NavMesh& navmesh, const sim::AgentConfig& agent,
    const TransferConfig& config,
    const std::vector<NodeTransferResult>& transferred,
    const std::vector<int>& path, float startHeading);

/// The paper's transfer statistics, summed over nodes and trajectories.
struct TransferStats {
  int64_t nodes = 0;           ///< nodes attempted
  int64_t nodes_valid = 0;     ///< transferred within max_displacement
  int64_t nodes_adjusted = 0;  ///< valid with displacement > adjusted_threshold
  double adjusted_displacement_sum = 0.0;  ///< metres, over adjusted nodes
  int64_t trajectories = 0;                ///< trajectories checked
  int64_t navigable = 0;
  int64_t failed_invalid_node = 0;
  int64_t failed_no_path = 0;
  int64_t failed_not_reached = 0;
  int64_t failed_detour = 0;
  int64_t actions = 0;  ///< ground-truth actions over navigable ones

  /// Counts `results` (one graph's nodes).
  void addNodes(const std::vector<NodeTransferResult>& results,
                const TransferConfig& config);
  /// Counts one checked trajectory.
  void addTrajectory(const NavigabilityResult& result);
  /// Adds another tally.
  void merge(const TransferStats& other);

  /// Share of nodes transferred (paper: 98.3%), in [0, 1].
  double nodeTransferRate() const;
  /// Share of valid nodes that needed horizontal adjustment (paper: 3%).
  double adjustedShare() const;
  /// Mean displacement of adjusted nodes, metres (paper: 0.19 m).
  double meanAdjustedDisplacement() const;
  /// Share of trajectories navigable (paper: 77%).
  double navigableRate() const;
  /// Mean ground-truth actions per navigable trajectory (paper: 55.88).
  double meanActions() const;

  /// Counts and the derived rates as a JSON object.
  nlohmann::json toJson() const;
  /// Multi-line report comparing each rate with the paper's value.
  std::string report() const;
  bool operator==(const TransferStats&) const = default;
};

}  // namespace vln::data
