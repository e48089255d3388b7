#pragma once
// Guards on scene geometry and on the positions given to the simulator's
// public API. Recast crashes on a mesh that is flat along a horizontal axis,
// and Debian's Embree is built with assertions, so a ray from 1e30 aborts
// the process; hostile geometry (a mesh authored Z-up or in millimetres,
// NaN or 1e30 coordinates, degenerate triangles, a camera far outside the
// scene) must end in std::invalid_argument before either library sees it.
// Found by the geometry fuzzer (fuzz/fuzz_geometry.cpp,
// docs/reliability.md).

#include <Eigen/Geometry>

#include <cstddef>
#include <string>
#include <string_view>

#include "common/Math.h"
#include "sim/Mesh.h"
#include "sim/SimConfig.h"

namespace vln::sim {

/// Most triangles a scene may have: 2^25 = 33,554,432. Recast counts
/// vertices and triangles in int, and a mesh of this size already holds
/// about 1 GB of positions, indices and per-triangle arrays.
inline constexpr size_t kMaxSceneTriangles = size_t{1} << 25;
/// Largest |coordinate| of a scene vertex in the world frame (after the
/// import scale), metres. Floats resolve 6 cm at 1e6 m; anything farther
/// is a unit mistake or a stray vertex.
inline constexpr float kMaxSceneCoordinate = 1e6f;
/// How far outside a scene's bounds positions given to the navmesh, the
/// agent, the ray tracer and the renderers may lie, metres.
inline constexpr float kPoseMargin = 100.0f;

/// Limits of checkSceneGeometry() (the defaults are the documented ones;
/// tests pass smaller ones).
struct GeometryLimits {
  size_t max_triangles = kMaxSceneTriangles;
  float max_coordinate = kMaxSceneCoordinate;
};

/// Throws std::invalid_argument naming `source` when `mesh` has more
/// triangles than limits.max_triangles (or more than three vertices per
/// allowed triangle), a vertex coordinate that is not finite or beyond
/// +-limits.max_coordinate, or no triangle of non-zero area in single
/// precision (all degenerate: repeated or collinear corners, or
/// coordinates so small that the area underflows). Does not repeat
/// TriangleMesh::validate()'s array checks.
void checkSceneGeometry(const TriangleMesh& mesh, std::string_view source,
                        const GeometryLimits& limits = {});

/// A warning sentence when `mesh` (world frame, imported with `config`)
/// looks as if its file has the other up axis, else "". Compares two
/// floors: the area of triangles facing world +Y (within 30 degrees) at
/// most a tenth of the mesh's height above the lowest of them (so the top
/// of a floor slab counts), and the same seen along where the other up
/// axis went: +Z for a file read Y-up (the floor of a Z-up file, e.g. a
/// glTF exported without the Y-up conversion), -Z for a file read Z-up.
/// The hint is given when the second is more than twice the first and more
/// than 5% of the mesh's area. A heuristic: a lone corridor whose walls are
/// more than twice as tall as it is wide gets the hint too.
std::string upAxisHint(const TriangleMesh& mesh, const MeshLoadConfig& config);

/// `bounds` grown by kPoseMargin on every side: where positions are
/// accepted.
Eigen::AlignedBox3f poseBounds(const Eigen::AlignedBox3f& bounds);

/// Throws std::invalid_argument "<method>: <what> (x y z) must be finite
/// and within ..." unless `p` is finite and inside `accepted` (a
/// poseBounds() box).
void checkPosition(std::string_view method, std::string_view what,
                   const Vec3f& p, const Eigen::AlignedBox3f& accepted);

}  // namespace vln::sim
