#pragma once
// Internal to the sim module (not part of its public API): Detour tile data
// in and out of memory, the part of NavMesh that trusts nothing. Encodes
// and decodes the .navmesh file (the Recast demo's "MSET" tile set, as
// Habitat-Sim writes it), and checks every tile, read from a file or built
// by Recast, before Detour sees it: Detour reads out of bounds or divides
// its way to NaN on corrupt tiles (found by fuzzing, docs/reliability.md).

#include <DetourNavMesh.h>

#include <memory>
#include <string>

#include "sim/SimConfig.h"

namespace vln::sim::detail {

/// Frees a Detour navmesh with dtFreeNavMesh.
struct DtNavMeshDeleter {
  void operator()(dtNavMesh* p) const { dtFreeNavMesh(p); }
};
using DtNavMeshPtr = std::unique_ptr<dtNavMesh, DtNavMeshDeleter>;

/// Checks that a tile's header counts fit its `size` and that every index
/// and coordinate in it is usable. Returns an empty string when the tile is
/// sound, else the reason.
std::string tileDataProblem(unsigned char* data, int size);

/// Detour's closestPointOnPoly dereferences a null pointer when no detail
/// triangle of a polygon has an edge flagged as lying on the polygon outline
/// (recastnavigation issues #394 and #656; Recast's flags can miss edges).
/// Such polygons get every detail edge flagged, which the maintainers note
/// is harmless: a false boundary only costs an extra distance test. Call on
/// tiles that passed tileDataProblem().
void ensureDetailBoundaryEdges(unsigned char* data);

/// The bytes of a .navmesh file holding every tile of `nav`: the set
/// header, then (tileRef, dataSize, data) per tile, in native byte order
/// like the Recast demo and Habitat.
std::string encodeNavMeshSet(const dtNavMesh& nav);

/// A navmesh read from .navmesh `bytes`, with the agent its first tile was
/// built for (the rest of the config stays default).
struct DecodedNavMesh {
  DtNavMeshPtr nav;
  NavMeshConfig config;
};

/// Decodes .navmesh `bytes`, checking every tile; like Habitat, a zero tile
/// ref or size ends the tile list early. Throws std::runtime_error starting
/// with `where` (e.g. "NavMesh::load(): <file>: ") and saying what is
/// corrupt.
DecodedNavMesh decodeNavMeshSet(const std::string& bytes,
                                const std::string& where);

}  // namespace vln::sim::detail
