#pragma once
// Scene files in and out. Import goes through assimp (.glb/.gltf, .obj+.mtl,
// .ply, ...) with vertex colours, materials and textures, converted to the
// world frame (+Y up, metres). Export writes .glb (binary glTF 2.0) or
// .obj+.mtl that any mesh viewer opens.
//
// Semantic object ids survive a round trip through node/group names:
// triangles of object 12 live in a node named "object_12" (and untagged ones
// in "structure"). Rooms, doors and object labels go to a sidecar
// "<scene file>.semantics.json", world frame, metres:
//   {"rooms":   [{"id", "type", "footprint": {"min": [x, z], "max": [x, z]},
//                 "floor_y"}],
//    "doors":   [{"room_a", "room_b", "center": [x, y, z], "width",
//                 "normal": [x, y, z]}],
//    "objects": [{"id", "category", "color", "room",
//                 "bounds": {"min": [x, y, z], "max": [x, y, z]}}]}
// Room references must name a room in "rooms" (or be -1).
//
// Exported .glb files are binary glTF 2.0 with unlit materials
// (KHR_materials_unlit), vertex colours as normalised RGBA bytes, embedded
// PNG textures with REPEAT sampling; .obj files carry vertex colours as
// "v x y z r g b", materials in a .mtl and textures as "<stem>_<name>.png".

#include <filesystem>

#include "sim/Mesh.h"
#include "sim/SimConfig.h"

namespace vln::sim {

/// A scene file's contents.
struct LoadedScene {
  TriangleMesh mesh;
  SceneSemantics semantics;  ///< from the sidecar; empty when there is none
};

/// Loads `file` and its semantics sidecar (if present), bringing positions
/// into the world frame: Z-up files map (x, y, z) to (x, z, -y) (Habitat's
/// convention), then everything is multiplied by config.scale. Node
/// transforms are applied; triangles under a node (or in a mesh) named
/// "object_<id>" get triangle_object = id, the rest -1 (the array stays
/// empty when no such name exists). Points, lines and triangles with a
/// repeated corner are dropped. uvs put v = 0 on the first image row. The
/// mesh keeps the
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
