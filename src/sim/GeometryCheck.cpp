#include "sim/GeometryCheck.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <utility>
#include <vector>

#include "common/Check.h"

namespace vln::sim {

namespace {

// A triangle "faces" a direction when its normal is within 30 degrees of it.
const float kFacingCosine = std::cos(degToRad(30.0f));
// upAxisHint(): a floor is what faces up within a tenth of the extent of
// the lowest up-facing triangle; the other axis's floor must be more than twice
// the +Y one and more than 5% of the whole mesh's area.
constexpr float kFloorBand = 0.1f;
constexpr double kHintRatio = 2.0;
constexpr double kHintShare = 0.05;

std::string boxText(const Eigen::AlignedBox3f& box) {
  std::ostringstream out;
  out << "[" << box.min().transpose() << "] to [" << box.max().transpose()
      << "]";
  return out.str();
}

}  // namespace

void checkSceneGeometry(const TriangleMesh& mesh, std::string_view source,
                        const GeometryLimits& limits) {
  // sizes first: everything after is linear in them
  VLN_CHECK_ARG(mesh.triangleCount() <= limits.max_triangles, source,
                ": the mesh has ", mesh.triangleCount(),
                " triangles, more than the limit of ", limits.max_triangles,
                " (sim::kMaxSceneTriangles)");
  VLN_CHECK_ARG(mesh.positions.size() <= 3 * limits.max_triangles, source,
                ": the mesh has ", mesh.positions.size(),
                " vertices, more than three per allowed triangle (",
                3 * limits.max_triangles, ")");

  // every coordinate finite and near the origin
  for (size_t i = 0; i < mesh.positions.size(); ++i) {
    const Vec3f& p = mesh.positions[i];
    VLN_CHECK_ARG(p.allFinite(), source, ": vertex ", i,
                  " has a non-finite coordinate (", p.transpose(), ")");
    VLN_CHECK_ARG(p.cwiseAbs().maxCoeff() <= limits.max_coordinate, source,
                  ": vertex ", i, " is at (", p.transpose(), "), beyond +-",
                  limits.max_coordinate,
                  " m of the origin: check the scale (sim.mesh.scale) or "
                  "recentre the mesh");
  }

  // at least one triangle with an area that single precision can see, as
  // Recast and Embree compute it (indices were checked by validate())
  const size_t n = mesh.triangleCount();
  for (size_t t = 0; t < n; ++t) {
    const uint32_t* corner = mesh.indices.data() + 3 * t;
    if (corner[0] >= mesh.positions.size() ||
        corner[1] >= mesh.positions.size() ||
        corner[2] >= mesh.positions.size())
      continue;
    const Vec3f& a = mesh.positions[corner[0]];
    const Vec3f normal =
        (mesh.positions[corner[1]] - a).cross(mesh.positions[corner[2]] - a);
    if (normal.squaredNorm() > 0.0f) return;
  }
  throw std::invalid_argument(strCat(
      source, ": all ", n,
      " triangles are degenerate (zero area in single precision: repeated "
      "or collinear corners, or coordinates too small; bounds ",
      boxText(mesh.bounds()), ")"));
}

namespace {

// The "floor" seen with `up` as the up direction: the area of triangles that
// face `up` (within 30 degrees) no higher than a tenth of the mesh's extent
// along `up` above the lowest such triangle. Measured from that triangle,
// not from the lowest vertex: under a floor slab (or a ground box) the
// lowest vertices face down, and a band starting there can miss the floor.
double floorArea(const TriangleMesh& mesh, const Vec3f& up) {
  float lowestVertex = std::numeric_limits<float>::infinity();
  float highestVertex = -lowestVertex;
  for (const Vec3f& p : mesh.positions) {
    lowestVertex = std::min(lowestVertex, p.dot(up));
    highestVertex = std::max(highestVertex, p.dot(up));
  }
  // the triangles facing `up`: (height of the centroid, area)
  std::vector<std::pair<float, double>> facing;
  for (size_t t = 0; t < mesh.triangleCount(); ++t) {
    const uint32_t* corner = mesh.indices.data() + 3 * t;
    const Vec3f& a = mesh.positions[corner[0]];
    const Vec3f& b = mesh.positions[corner[1]];
    const Vec3f& c = mesh.positions[corner[2]];
    const Vec3f normal = (b - a).cross(c - a);
    const float length = normal.norm();
    if (!(length > 0.0f) || !std::isfinite(length)) continue;
    if (normal.dot(up) <= kFacingCosine * length) continue;
    facing.emplace_back((a + b + c).dot(up) / 3.0f, 0.5 * length);
  }
  float lowest = std::numeric_limits<float>::infinity();
  for (const auto& [height, area] : facing) lowest = std::min(lowest, height);
  const float ceiling = lowest + kFloorBand * (highestVertex - lowestVertex);
  double total = 0.0;
  for (const auto& [height, area] : facing)
    if (height <= ceiling) total += area;
  return total;
}

}  // namespace

std::string upAxisHint(const TriangleMesh& mesh, const MeshLoadConfig& config) {
  // where the other interpretation's up went: a Z-up file read Y-up keeps
  // its floor facing +Z; a Y-up file read Z-up ((x, y, z) -> (x, z, -y))
  // has its floor facing -Z
  const bool readYUp = config.up_axis == UpAxis::kY;
  const Vec3f otherUp(0.0f, 0.0f, readYUp ? 1.0f : -1.0f);
  double total = 0.0;
  for (size_t t = 0; t < mesh.triangleCount(); ++t) {
    const uint32_t* corner = mesh.indices.data() + 3 * t;
    const Vec3f& a = mesh.positions[corner[0]];
    const float length = (mesh.positions[corner[1]] - a)
                             .cross(mesh.positions[corner[2]] - a)
                             .norm();
    if (std::isfinite(length)) total += 0.5 * length;
  }
  const double floorUp = floorArea(mesh, Vec3f::UnitY());
  const double floorOther = floorArea(mesh, otherUp);
  if (!(floorOther > kHintRatio * floorUp && floorOther > kHintShare * total))
    return "";
  std::ostringstream out;
  out.precision(3);
  out << "it looks " << (readYUp ? "Z-up" : "Y-up") << ": read "
      << (readYUp ? "Y-up" : "Z-up") << ", its floor faces "
      << (readYUp ? "+Z" : "-Z") << " (" << floorOther
      << " m^2 at the bottom facing that way, " << floorUp
      << " m^2 facing up); if so, set sim.mesh.up_axis: "
      << (readYUp ? "z" : "y") << " (vlnce-sim --up-axis "
      << (readYUp ? "z" : "y") << ")";
  return out.str();
}

Eigen::AlignedBox3f poseBounds(const Eigen::AlignedBox3f& bounds) {
  if (bounds.isEmpty()) return bounds;
  const Vec3f margin = Vec3f::Constant(kPoseMargin);
  return Eigen::AlignedBox3f(bounds.min() - margin, bounds.max() + margin);
}

void checkPosition(std::string_view method, std::string_view what,
                   const Vec3f& p, const Eigen::AlignedBox3f& accepted) {
  VLN_CHECK_ARG(p.allFinite(), method, ": ", what, " must be finite, got (",
                p.transpose(), ")");
  VLN_CHECK_ARG(accepted.contains(p), method, ": ", what, " (", p.transpose(),
                ") is outside the scene: positions must lie "
                "within its bounds plus ",
                kPoseMargin, " m, ", boxText(accepted));
}

}  // namespace vln::sim
