#pragma once
// Scene files in and out: the entry points over the importer
// (MeshImport.h: assimp, .glb/.gltf, .obj+.mtl, .ply, ...), the writers
// (GlbWriter.h: binary glTF 2.0; ObjWriter.h: .obj+.mtl, which any mesh
// viewer opens) and the semantics sidecar "<scene file>.semantics.json"
// (SceneSemanticsFile.h). Everything is world frame (+Y up, metres).
//
// Semantic object ids survive a round trip through node/group names
// (SceneFileLayout.h): triangles of object 12 live in a node named
// "object_12", untagged ones in "structure".

#include <filesystem>

#include "sim/Mesh.h"
#include "sim/SimConfig.h"

namespace vln::sim {

/// A scene file's contents.
struct LoadedScene {
  TriangleMesh mesh;
  SceneSemantics semantics;  ///< from the sidecar; empty when there is none
};

/// Loads `file` (importMesh(), MeshImport.h: world frame, config.scale,
/// object ids from node names, points/lines/degenerate triangles dropped)
/// and its semantics sidecar, if present. The mesh keeps the materials and
/// textures its triangles use, numbered in order of first use (for every
/// format; assimp's glTF reader drops unused ones anyway), so a saved mesh
/// comes back with equal triangles, colours, uvs and per-triangle
/// materials, and with equal material/texture lists when those were
/// already all used in that order. Logs a warning when the mesh looks as if
/// the file had the other up axis (upAxisHint(), GeometryCheck.h). Throws
/// std::runtime_error naming the file when it is missing or assimp cannot
/// parse it, and std::invalid_argument when it has no triangles, invalid
/// or hostile geometry (NaN, bad indices, the limits of GeometryCheck.h),
/// `config` is out of its bounds or its sidecar is invalid.
LoadedScene loadScene(const std::filesystem::path& file,
                      const MeshLoadConfig& config);

/// Writes `mesh` to `file` (.glb or .obj by extension; .obj also writes a
/// .mtl and PNG textures beside it) and `semantics` to the sidecar when it is
/// not empty (otherwise a stale sidecar is removed). Atomic per file. Throws
/// std::invalid_argument for other extensions and for an invalid mesh,
/// before writing anything.
void saveScene(const std::filesystem::path& file, const TriangleMesh& mesh,
               const SceneSemantics& semantics = {});

}  // namespace vln::sim
