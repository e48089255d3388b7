#pragma once
// Internal to the sim module (not part of its public API): the Recast half of
// NavMesh::build(), which turns a triangle soup into one Detour tile exactly
// as Habitat-Sim's PathFinder::build does (solo mesh, watershed regions).
// Kept apart from NavMesh.cpp so the query code does not include Recast.

#include <cstdint>
#include <memory>

#include "sim/Mesh.h"
#include "sim/SimConfig.h"

namespace vln::sim::detail {

/// Polygon flags, identical to Habitat-Sim's PolyFlags so that .navmesh files
/// move between the two unchanged.
inline constexpr uint16_t kPolyFlagWalk = 0x01;
inline constexpr uint16_t kPolyFlagDoor = 0x02;
inline constexpr uint16_t kPolyFlagDisabled = 0x04;
/// Area id of every walkable polygon (Habitat POLYAREA_GROUND).
inline constexpr uint8_t kPolyAreaGround = 0;

/// Frees Detour tile data with dtFree (it was allocated with dtAlloc).
struct DetourDataDeleter {
  void operator()(unsigned char* data) const;
};
using DetourData = std::unique_ptr<unsigned char, DetourDataDeleter>;

/// One serialised Detour tile (dtCreateNavMeshData output).
struct DetourTile {
  DetourData data;
  int size = 0;  ///< bytes
};

/// Runs the Recast pipeline on `mesh` (world frame, +Y up, metres) with
/// `config` and packs the result as a single Detour tile. Throws
/// std::invalid_argument when `config` is out of bounds, the mesh is
/// invalid or nothing is walkable, and std::runtime_error with Recast's own
/// log when a build stage fails (e.g. too many vertices).
DetourTile buildDetourTile(const TriangleMesh& mesh,
                           const NavMeshConfig& config);

}  // namespace vln::sim::detail
