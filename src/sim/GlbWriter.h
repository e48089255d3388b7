#pragma once
// Internal to vln_sim (saveScene() in MeshIo.h is the entry point): the
// binary glTF 2.0 (.glb) writer.
//
// A written file holds one node (and mesh) per semantic object in the
// layout of SceneFileLayout.h, one primitive per material; unlit materials
// (KHR_materials_unlit), so viewers show the baked vertex colours
// unchanged; vertex colours as normalised RGBA bytes; textures as embedded
// PNG images with REPEAT sampling.

#include <filesystem>

#include "sim/Mesh.h"

namespace vln::sim {

/// Writes `mesh` (valid: TriangleMesh::validate()) to `file` as .glb,
/// atomically. Materials and textures are written in order of first use.
/// Throws std::invalid_argument when the file would exceed the format's
/// 4 GiB limit and std::runtime_error when it cannot be written.
void writeGlb(const std::filesystem::path& file, const TriangleMesh& mesh);

}  // namespace vln::sim
