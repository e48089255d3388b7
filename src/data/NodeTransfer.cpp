#include "data/NodeTransfer.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "common/Check.h"
#include "sim/Follower.h"

namespace vln::data {

namespace {

// A trajectory waypoint counts as reached when the follower's stopping
// distance is within the radius; this slack absorbs float rounding of the
// path length Detour reports.
constexpr float kReachSlack = 1e-4f;

double ratio(int64_t numerator, int64_t denominator) {
  return denominator > 0
             ? static_cast<double>(numerator) / static_cast<double>(denominator)
             : 0.0;
}

}  // namespace

// =========================================================================
// node transfer
// =========================================================================

std::vector<bool> floorIslands(const sim::NavMesh& navmesh, float minArea) {
  std::vector<bool> floors(static_cast<size_t>(navmesh.islandCount()), false);
  for (int i = 0; i < navmesh.islandCount(); ++i)
    floors[static_cast<size_t>(i)] = i == 0 || navmesh.islandArea(i) >= minArea;
  return floors;
}

NodeTransferResult transferNode(const sim::NavMesh& navmesh, const Vec3f& node,
                                const TransferConfig& config,
                                const std::vector<bool>& floors) {
  VLN_CHECK_ARG(node.allFinite(),
                "transferNode(): node position must be finite, got [",
                node.transpose(), "]");
  // the search box is as wide as the largest allowed displacement and only
  // as tall as the tolerance of the navmesh height, so each sample sees the
  // surfaces at its own height: table tops high on the ray, floors low
  const Vec3f halfExtents(config.max_displacement, config.snap_vertical_extent,
                          config.max_displacement);
  const int samples = static_cast<int>(std::floor(
                          config.cast_distance / config.cast_step + 1e-4f)) +
                      1;

  NodeTransferResult best;
  float bestDisplacement = std::numeric_limits<float>::infinity();
  for (int k = 0; k < samples; ++k) {
    // project the sample, keep it only on a floor a ground agent can use
    const Vec3f sample =
        node - Vec3f(0.0f, static_cast<float>(k) * config.cast_step, 0.0f);
    const auto snapped = navmesh.snapPoint(sample, halfExtents);
    if (!snapped) continue;
    const int island = navmesh.islandIndex(*snapped);
    if (island < 0 || static_cast<size_t>(island) >= floors.size() ||
        !floors[static_cast<size_t>(island)])
      continue;

    // least horizontal displacement wins; the box corners reach beyond the
    // allowed radius, so the radius is checked here
    const float displacement = horizontalDistance(*snapped, node);
    if (displacement > config.max_displacement) continue;
    if (displacement < bestDisplacement) {
      bestDisplacement = displacement;
      best.valid = true;
      best.waypoint = *snapped;
      best.displacement = displacement;
      best.island = island;
    }
  }
  return best;
}

std::vector<NodeTransferResult> transferGraph(const NavGraph& graph,
                                              const sim::NavMesh& navmesh,
                                              const TransferConfig& config) {
  const std::vector<bool> floors =
      floorIslands(navmesh, config.min_floor_island_area);
  std::vector<NodeTransferResult> results;
  results.reserve(static_cast<size_t>(graph.numNodes()));
  for (int i = 0; i < graph.numNodes(); ++i)
    results.push_back(
        transferNode(navmesh, graph.node(i).position, config, floors));
  return results;
}

// =========================================================================
// navigability and ground truth
// =========================================================================

std::string navigabilityFailureName(NavigabilityFailure failure) {
  switch (failure) {
    case NavigabilityFailure::kNone:
      return "none";
    case NavigabilityFailure::kInvalidNode:
      return "invalid_node";
    case NavigabilityFailure::kNoPath:
      return "no_path";
    case NavigabilityFailure::kNotReached:
      return "not_reached";
    case NavigabilityFailure::kDetour:
      return "detour";
  }
  VLN_ASSERT(false);
  return {};
}

NavigabilityResult checkNavigability(const sim::NavMesh& navmesh,
                                     const sim::AgentConfig& agent,
                                     const TransferConfig& config,
                                     const std::vector<Vec3f>& waypoints,
                                     float startHeading) {
  VLN_CHECK_ARG(waypoints.size() >= 2,
                "checkNavigability(): a trajectory needs at least two "
                "waypoints, got ",
                waypoints.size());
  NavigabilityResult result;
  result.geodesic_distance =
      navmesh.geodesicDistance(waypoints.front(), waypoints.back());

  const sim::ShortestPathFollower follower(navmesh, agent,
                                           config.follower_goal_radius);
  GroundTruthPath path;
  sim::AgentState state{waypoints.front(), wrapAngle(startHeading)};
  path.locations.push_back(state.position);

  for (size_t leg = 0; leg + 1 < waypoints.size(); ++leg) {
    // the A* path to the next waypoint must exist
    const Vec3f& target = waypoints[leg + 1];
    const float geodesic = navmesh.geodesicDistance(state.position, target);
    if (!std::isfinite(geodesic)) {
      result.failure = NavigabilityFailure::kNoPath;
      result.failed_index = static_cast<int>(leg);
      return result;
    }

    // a long way round means the scene blocks the edge (optional check)
    if (config.max_leg_detour > 0.0f) {
      const float straight = (target - waypoints[leg]).norm();
      const float around = navmesh.geodesicDistance(waypoints[leg], target);
      if (around > config.max_leg_detour * std::max(straight, 1.0f)) {
        result.failure = NavigabilityFailure::kDetour;
        result.failed_index = static_cast<int>(leg);
        return result;
      }
    }

    // follow it from wherever the previous leg ended, as the agent would
    const int cap =
        config.leg_base_steps +
        static_cast<int>(std::ceil(config.leg_steps_per_meter * geodesic));
    bool stopped = false;
    for (int step = 0; step <= cap; ++step) {
      const sim::Action action = follower.nextAction(state, target);
      if (action == sim::Action::kStop) {
        stopped = true;
        break;
      }
      if (step == cap) break;
      const Vec3f before = state.position;
      sim::applyAction(navmesh, agent, state, action);
      path.actions.push_back(action);
      if (action == sim::Action::kMoveForward) ++path.forward_steps;
      // VLN-CE records a location whenever the position changes
      if (state.position != before) path.locations.push_back(state.position);
    }

    // the follower also stops when the goal became unreachable, so the
    // remaining distance decides
    const float remaining = navmesh.geodesicDistance(state.position, target);
    if (!stopped || !(remaining <= config.follower_goal_radius + kReachSlack)) {
      result.failure = NavigabilityFailure::kNotReached;
      result.failed_index = static_cast<int>(leg);
      return result;
    }
  }

  path.actions.push_back(sim::Action::kStop);
  result.ground_truth = std::move(path);
  return result;
}

NavigabilityResult checkNavigability(
    const sim::NavMesh& navmesh, const sim::AgentConfig& agent,
    const TransferConfig& config,
    const std::vector<NodeTransferResult>& transferred,
    const std::vector<int>& path, float startHeading) {
  std::vector<Vec3f> waypoints;
  waypoints.reserve(path.size());
  for (size_t i = 0; i < path.size(); ++i) {
    const int node = path[i];
    VLN_CHECK_ARG(node >= 0 && static_cast<size_t>(node) < transferred.size(),
                  "checkNavigability(): node index ", node,
                  " is outside the graph of ", transferred.size(), " nodes");
    const NodeTransferResult& t = transferred[static_cast<size_t>(node)];
    if (!t.valid) {
      NavigabilityResult result;
      result.failure = NavigabilityFailure::kInvalidNode;
      result.failed_index = static_cast<int>(i);
      return result;
    }
    waypoints.push_back(t.waypoint);
  }
  return checkNavigability(navmesh, agent, config, waypoints, startHeading);
}

// =========================================================================
// statistics
// =========================================================================

void TransferStats::addNodes(const std::vector<NodeTransferResult>& results,
                             const TransferConfig& config) {
  for (const NodeTransferResult& r : results) {
    ++nodes;
    if (!r.valid) continue;
    ++nodes_valid;
    if (r.displacement > config.adjusted_threshold) {
      ++nodes_adjusted;
      adjusted_displacement_sum += r.displacement;
    }
  }
}

void TransferStats::addTrajectory(const NavigabilityResult& result) {
  ++trajectories;
  switch (result.failure) {
    case NavigabilityFailure::kNone:
      ++navigable;
      actions += static_cast<int64_t>(result.ground_truth.actions.size());
      break;
    case NavigabilityFailure::kInvalidNode:
      ++failed_invalid_node;
      break;
    case NavigabilityFailure::kNoPath:
      ++failed_no_path;
      break;
    case NavigabilityFailure::kNotReached:
      ++failed_not_reached;
      break;
    case NavigabilityFailure::kDetour:
      ++failed_detour;
      break;
  }
}

void TransferStats::merge(const TransferStats& o) {
  nodes += o.nodes;
  nodes_valid += o.nodes_valid;
  nodes_adjusted += o.nodes_adjusted;
  adjusted_displacement_sum += o.adjusted_displacement_sum;
  trajectories += o.trajectories;
  navigable += o.navigable;
  failed_invalid_node += o.failed_invalid_node;
  failed_no_path += o.failed_no_path;
  failed_not_reached += o.failed_not_reached;
  failed_detour += o.failed_detour;
  actions += o.actions;
}

double TransferStats::nodeTransferRate() const {
  return ratio(nodes_valid, nodes);
}
double TransferStats::adjustedShare() const {
  return ratio(nodes_adjusted, nodes_valid);
}
double TransferStats::meanAdjustedDisplacement() const {
  return nodes_adjusted > 0
             ? adjusted_displacement_sum / static_cast<double>(nodes_adjusted)
             : 0.0;
}
double TransferStats::navigableRate() const {
  return ratio(navigable, trajectories);
}
double TransferStats::meanActions() const { return ratio(actions, navigable); }

nlohmann::json TransferStats::toJson() const {
  return {
      {"nodes", nodes},
      {"nodes_valid", nodes_valid},
      {"nodes_adjusted", nodes_adjusted},
      {"node_transfer_rate", nodeTransferRate()},
      {"adjusted_share", adjustedShare()},
      {"mean_adjusted_displacement", meanAdjustedDisplacement()},
      {"trajectories", trajectories},
      {"trajectories_navigable", navigable},
      {"failed_invalid_node", failed_invalid_node},
      {"failed_no_path", failed_no_path},
      {"failed_not_reached", failed_not_reached},
      {"failed_detour", failed_detour},
      {"navigable_rate", navigableRate()},
      {"mean_actions", meanActions()},
  };
}

std::string TransferStats::report() const {
  // the paper's values: Section 3.2 and Fig. 3 of Krantz et al. 2020
  char buffer[1024];
  std::snprintf(
      buffer, sizeof(buffer),
      "nodes transferred:            %lld / %lld = %.1f%%   (paper 98.3%%)\n"
      "nodes adjusted:               %lld = %.1f%% of transferred   (paper "
      "3%%)\n"
      "mean adjusted displacement:   %.3f m   (paper 0.19 m)\n"
      "trajectories navigable:       %lld / %lld = %.1f%%   (paper 77%%)\n"
      "  failed: invalid node %lld, no path %lld, not reached %lld, detour "
      "%lld\n"
      "mean actions per trajectory:  %.2f   (paper 55.88)\n",
      static_cast<long long>(nodes_valid), static_cast<long long>(nodes),
      100.0 * nodeTransferRate(), static_cast<long long>(nodes_adjusted),
      100.0 * adjustedShare(), meanAdjustedDisplacement(),
      static_cast<long long>(navigable), static_cast<long long>(trajectories),
      100.0 * navigableRate(), static_cast<long long>(failed_invalid_node),
      static_cast<long long>(failed_no_path),
      static_cast<long long>(failed_not_reached),
      static_cast<long long>(failed_detour), meanActions());
  return buffer;
}

}  // namespace vln::data
