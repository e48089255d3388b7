#pragma once
// Internal to vln_sim: the layout every scene file format shares, used by
// the importer (MeshImport.cpp) and both writers (GlbWriter.cpp,
// ObjWriter.cpp), so that what one writes the other reads back.
//
// Semantic object ids survive a round trip through node/group names: the
// triangles of object 12 live in a node named "object_12", untagged ones in
// "structure". Inside a node, triangles are grouped by material; materials
// and textures are kept in order of first use. Textures are stored as PNG.

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "sim/Mesh.h"

namespace vln::sim {

/// Node name prefix of a semantic object ("object_<id>").
inline constexpr std::string_view kObjectPrefix = "object_";
/// Node name of the triangles of no object.
inline constexpr std::string_view kStructureNode = "structure";

/// "object_<id>" -> id; anything else (including "object_12a") -> nullopt.
std::optional<int> parseObjectName(std::string_view name);

/// The node name of `object`: "object_<id>", or "structure" when < 0.
std::string groupName(int object);

/// Triangle indices grouped the way both writers lay them out: one group
/// per semantic object (-1 = structure), inside it one run per material
/// (-1 = none), both in ascending order.
using TriangleGroups = std::map<int, std::map<int, std::vector<uint32_t>>>;

/// The groups of `mesh`.
TriangleGroups groupTriangles(const TriangleMesh& mesh);

/// Renumbers materials in order of first use by triangles (in `order`, or
/// the mesh's own order) and drops unused ones; then the same for textures
/// in order of first use by the kept materials.
void keepUsedMaterials(TriangleMesh& mesh,
                       const std::vector<uint32_t>* order = nullptr);

/// PNG bytes of an RGB8 texture. Throws std::runtime_error naming the
/// texture when OpenCV cannot encode it.
std::string encodePng(const Texture& texture);

}  // namespace vln::sim
