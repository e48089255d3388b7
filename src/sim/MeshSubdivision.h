#pragma once
// Dense meshes for rendering benchmarks (the large-scene target of
// `vlnce-sim bench --subdivide`): every triangle split into smaller ones on
// the same surface, so images stay the same while the triangle count grows.

#include "sim/Mesh.h"

namespace vln::sim {

/// `mesh` with every triangle split into n x n smaller ones on a
/// barycentric grid (each edge cut into n pieces), in triangle order.
/// Vertex colours (rounded) and uvs are interpolated, per-triangle
/// materials and object ids inherited; materials and textures are copied.
/// Each piece keeps its parent's winding. Every parent triangle gets its own
/// (n + 1)(n + 2) / 2 vertices, none shared with another parent, so n = 1
/// gives the same triangles with unshared vertices. Throws
/// std::invalid_argument when n < 1.
TriangleMesh subdivide(const TriangleMesh& mesh, int n);

}  // namespace vln::sim
