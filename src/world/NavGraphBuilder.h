#pragma once
// The R2R nav-graph of a procedural house, placed the way Matterport camera
// operators placed panoramas: nodes every ~2 m covering each room and in the
// doorways, at tripod height (1.2-1.6 m above the floor), kept off
// furniture except, now and then, right over a large table or counter, and
// over holes in the floor where the reconstruction failed (the cases the
// paper's transfer has to repair). Edges join nodes that see each other at
// camera height within ~3.75 m, as R2R's ray-traced (then hand-pruned)
// edges.
//
// Positions are world frame (+Y up, metres); node positions are camera
// centres, not feet.

#include <cstdint>
#include <string>
#include <vector>

#include "data/NavGraph.h"
#include "sim/Mesh.h"
#include "sim/RayTracer.h"
#include "world/WorldConfig.h"

namespace vln::world {

/// Why a node is where it is.
enum class NodePlacement {
  kRoom,       ///< on the room's grid, on the floor
  kDoorway,    ///< in the opening between two rooms
  kFurniture,  ///< over a large flat object (table, counter, bed)
  kHole,       ///< over a hole in the floor mesh
};

/// "room", "doorway", "furniture", "hole".
std::string nodePlacementName(NodePlacement placement);

/// A house's nav-graph with what the builder knows about each node.
struct BuiltNavGraph {
  data::NavGraph graph;
  /// Per node (graph index): how it was placed.
  std::vector<NodePlacement> placement;
  /// Per node: index into semantics.rooms of its room (room_a for doorway
  /// nodes).
  std::vector<int> room;
  /// Number of floor holes found in the mesh.
  int holes_found = 0;
};

/// Builds the nav-graph of a house from its room, door and object
/// `semantics` and a ray tracer over its mesh, with node ids that are 32 hex
/// digits derived from `seed`, like R2R viewpoint ids. Deterministic for
/// equal houses, configs and seeds. Throws std::invalid_argument when there
/// are no rooms.
BuiltNavGraph buildNavGraph(const sim::SceneSemantics& semantics,
                            const sim::RayTracer& tracer,
                            const NavGraphBuildConfig& config, uint64_t seed);

/// Sizes of the connected components of `graph`, largest first.
std::vector<int> componentSizes(const data::NavGraph& graph);

}  // namespace vln::world
