#pragma once
// Internal to vln_sim (loadScene() in MeshIo.h is the entry point): scene
// meshes read through assimp (.glb/.gltf, .obj+.mtl, .ply, ...) with vertex
// colours, materials and textures, converted to the world frame (+Y up,
// metres).
//
// Debian's assimp 5.2 crashes, hangs or allocates gigabytes on some
// malformed files (all found by fuzzing, docs/reliability.md), so input is
// guarded on both sides of its reader: PLY files are checked before assimp
// sees them (PlyCheck.h), and the faces it returns are checked before its
// post-processing runs.

#include <filesystem>

#include "sim/Mesh.h"
#include "sim/SimConfig.h"

namespace vln::sim {

/// The triangles of `file`, brought into the world frame: Z-up files map
/// (x, y, z) to (x, z, -y) (Habitat's convention), then everything is
/// multiplied by config.scale. Node transforms are applied; triangles under
/// a node (or in a mesh) named "object_<id>" get triangle_object = id, the
/// rest -1 (the array stays empty when no such name exists;
/// SceneFileLayout.h). Points, lines and triangles with a repeated corner
/// are dropped; exactly equal vertices are joined. uvs put v = 0 on the
/// first image row. The mesh keeps the materials and textures its triangles
/// use, numbered in order of first use. Throws std::runtime_error naming
/// the file when it is missing or assimp cannot parse it, and
/// std::invalid_argument when `config` is outside its bounds or the file
/// has no triangles, invalid geometry (NaN, bad indices), fails a guard,
/// or fails checkSceneGeometry() (GeometryCheck.h: more than
/// kMaxSceneTriangles triangles, a coordinate beyond kMaxSceneCoordinate,
/// only degenerate triangles).
TriangleMesh importMesh(const std::filesystem::path& file,
                        const MeshLoadConfig& config);

}  // namespace vln::sim
