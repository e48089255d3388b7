#pragma once
// The semantics sidecar of a scene file, "<scene file>.semantics.json":
// rooms, doors and object labels, world frame (+Y up), metres:
//   {"rooms":   [{"id", "type", "footprint": {"min": [x, z], "max": [x, z]},
//                 "floor_y"}],
//    "doors":   [{"room_a", "room_b", "center": [x, y, z], "width",
//                 "normal": [x, y, z]}],
//    "objects": [{"id", "category", "color", "room",
//                 "bounds": {"min": [x, y, z], "max": [x, y, z]}}]}
// Room references must name a room in "rooms" (or be -1). loadScene() and
// saveScene() (MeshIo.h) read and write it beside the scene.

#include <filesystem>

#include "sim/Mesh.h"

namespace vln::sim {

/// Path of the semantics sidecar of a scene file.
std::filesystem::path semanticsPath(const std::filesystem::path& sceneFile);

/// Reads a semantics sidecar. Throws naming the file and field on errors.
SceneSemantics loadSemantics(const std::filesystem::path& file);
/// Writes a semantics sidecar atomically.
void saveSemantics(const std::filesystem::path& file,
                   const SceneSemantics& semantics);

}  // namespace vln::sim
