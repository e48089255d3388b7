#pragma once
// RxR-like paths on a nav-graph: random walks that never revisit a node and
// never turn by more than max_turn at a node. Unlike R2R's shortest paths
// they may detour, and with 8-14 nodes they are about twice as long and
// cross more rooms, as RxR's annotated paths are (Ku et al. 2020).

#include <cstdint>
#include <optional>
#include <vector>

#include "data/NavGraph.h"
#include "sim/Mesh.h"
#include "world/RxrWorldConfig.h"
#include "world/TrajectorySampler.h"

namespace vln::world {

/// One random walk on `graph` drawn with `seed`: a uniform start node, a
/// node count uniform in [min_nodes, max_nodes], each next node uniform
/// among the unvisited neighbours within max_turn degrees (horizontal) of
/// the previous edge's direction. nullopt when the walk gets stuck or its
/// length (along its edges, metres) or straight start-to-goal distance fall
/// outside `config`. Deterministic for a given seed.
std::optional<GraphPath> sampleRxrWalk(const data::NavGraph& graph,
                                       const RxrTrajectoryConfig& config,
                                       uint64_t seed);

/// The number of distinct rooms `waypoints` pass through (world frame,
/// metres; points outside every room are not counted).
int roomsVisited(const sim::SceneSemantics& semantics,
                 const std::vector<Vec3f>& waypoints);

}  // namespace vln::world
