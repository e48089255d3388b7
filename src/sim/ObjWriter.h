#pragma once
// Internal to vln_sim (saveScene() in MeshIo.h is the entry point): the
// Wavefront .obj + .mtl writer.
//
// A written .obj carries vertex colours as "v x y z r g b", one group
// ("o") per semantic object in the layout of SceneFileLayout.h, inside it
// one "usemtl" run per material; the materials go to "<stem>.mtl" beside
// it (unlit: colour = Kd x vertex colour x map_Kd) and the textures to
// "<stem>_<texture name>.png".

#include <filesystem>

#include "sim/Mesh.h"

namespace vln::sim {

/// Writes `mesh` (valid: TriangleMesh::validate()) to `file` as .obj, with
/// its .mtl and PNG textures beside it, each file atomically. Throws
/// std::invalid_argument when two materials or two textures would get the
/// same name, or a material is named assimp's "DefaultMaterial" (reserved
/// for triangles without one), and std::runtime_error when a file cannot be
/// written.
void writeObj(const std::filesystem::path& file, const TriangleMesh& mesh);

}  // namespace vln::sim
