#pragma once
// Scene files in and out. Import goes through assimp (.glb/.gltf, .obj+.mtl,
// .ply, ...) with vertex colours, materials and textures, converted to the
// world frame (+Y up, metres). Export writes .glb (binary glTF 2.0) or
// .obj+.mtl that any mesh viewer opens.
//
// Semantic object ids survive a round trip through node/group names:
// triangles of object 12 live in a node named "object_12". Rooms, doors and
// object labels go to a sidecar "<scene file>.semantics.json".

#include <filesystem>

#include "sim/Mesh.h"
#include "sim/SimConfig.h"

namespace vln::sim {

/// A scene file's contents.
struct LoadedScene {
  TriangleMesh mesh;
  SceneSemantics semantics;  ///< from the sidecar; empty when there is none
};

/// Loads `file` and its semantics sidecar (if present). The mesh keeps the
/// materials and textures its triangles use, numbered in order of first use
/// (for every format; assimp's glTF reader drops unused ones anyway), so a
/// saved mesh comes back with equal triangles, colours, uvs and per-triangle
/// materials, and with equal material/texture lists when those were already
/// all used in that order. Throws
/// std::runtime_error naming the file when it is missing or assimp cannot
/// parse it, and std::invalid_argument when it has no triangles or invalid
/// geometry (NaN, bad indices).
LoadedScene loadScene(const std::filesystem::path& file,
                      const MeshLoadConfig& config);

/// Writes `mesh` to `file` (.glb or .obj by extension; .obj also writes a
/// .mtl and PNG textures beside it) and `semantics` to the sidecar when it is
/// not empty. Atomic per file. Throws std::invalid_argument for other
/// extensions.
void saveScene(const std::filesystem::path& file, const TriangleMesh& mesh,
               const SceneSemantics& semantics = {});

/// Path of the semantics sidecar of a scene file.
std::filesystem::path semanticsPath(const std::filesystem::path& sceneFile);

/// Reads a semantics sidecar. Throws naming the file and field on errors.
SceneSemantics loadSemantics(const std::filesystem::path& file);
/// Writes a semantics sidecar atomically.
void saveSemantics(const std::filesystem::path& file,
                   const SceneSemantics& semantics);

}  // namespace vln::sim
