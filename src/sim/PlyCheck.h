#pragma once
// Internal to vln_sim (used by MeshImport.cpp): the PLY guard loadScene runs
// before handing a file to assimp.

#include <filesystem>

namespace vln::sim {

/// Does nothing for a file that is not PLY (neither a .ply extension nor
/// the "ply" magic). For a PLY file, checks the header line by line and
/// then walks the body (ASCII or binary) against the declared elements:
/// every row present, every list count within its type and within the
/// data left. Throws std::invalid_argument naming the file, and the
/// element, row and property where there is one.
///
/// Debian's assimp 5.2 PLY reader hangs, corrupts its heap or allocates
/// gigabytes on files that break these rules (all found by fuzzing,
/// docs/reliability.md), so they never reach it.
void checkPlyFile(const std::filesystem::path& file);

}  // namespace vln::sim
