#pragma once
// How a reconstructed scene differs from what its panoramas saw. The VLN-CE
// paper traces most non-navigable trajectories to such differences: doors
// closed and objects (chairs) moved between captures, so that the mesh
// blocks a path the nav-graph's annotators connected, or covers a node. The
// nav-graph is placed in the house as captured; these changes are then made
// to the scene agents move in (ReconstructionConfig, WorldGenerator.h step
// 2). World frame, +Y up, metres.

#include <cstdint>

namespace vln::world {

struct BuiltNavGraph;  // NavGraphBuilder.h
struct House;          // HouseGenerator.h
struct WorldConfig;    // WorldConfig.h

/// What applyCaptureDifferences() changed.
struct CaptureDifferences {
  int closed_doors = 0;   ///< interior doorways closed by a door leaf
  int moved_objects = 0;  ///< movable objects copied onto a nav-graph node
};

/// Makes `house` differ from its capture: closes each interior doorway with
/// probability reconstruction.closed_door_probability (a 4 cm leaf up to
/// 2.1 m, below the ceiling) and, per node of `built` with probability
/// reconstruction.moved_object_probability, copies a movable object of the
/// node's room (standing, at most 0.5 m^2 and 1.3 m high) to within
/// moved_object_offset of the node when it stays inside the room and clear
/// of other furniture (a new semantic object). Draws from a generator
/// seeded with `seed` only.
CaptureDifferences applyCaptureDifferences(House& house,
                                           const BuiltNavGraph& built,
                                           const WorldConfig& config,
                                           uint64_t seed);

}  // namespace vln::world
