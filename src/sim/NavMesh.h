#pragma once
// Navigable space of a scene, built with Recast and queried with Detour (the
// library Habitat-Sim uses). Points are world frame (+Y up, metres) at the
// agent's feet.

#include <cstdint>
#include <filesystem>
#include <limits>
#include <memory>
#include <optional>
#include <random>
#include <vector>

#include "common/Math.h"
#include "sim/Mesh.h"
#include "sim/SimConfig.h"

namespace vln::sim {

/// Geodesic distance reported between unconnected points.
inline constexpr float kUnreachable = std::numeric_limits<float>::infinity();

/// A Detour navmesh with Habitat-like queries. All const methods are safe to
/// call from several threads at once. Query points must be finite and lie
/// within queryBounds() (the navmesh's bounds grown by kPoseMargin,
/// GeometryCheck.h); queries throw std::invalid_argument otherwise, naming
/// the method and the point.
class NavMesh {
 public:
  /// Builds the navmesh of `mesh` with Recast. Throws std::invalid_argument
  /// when the mesh fails checkSceneGeometry() (GeometryCheck.h), spans more
  /// than 1e8 cells (or 65535 along x or z), is less than one cell across
  /// along x or z, or yields no walkable surface.
  static std::unique_ptr<NavMesh> build(const TriangleMesh& mesh,
                                        const NavMeshConfig& config);
  /// Loads a navmesh saved by save() or by Habitat-Sim (.navmesh, the Recast
  /// "MSET" tile-set layout). Throws std::runtime_error naming the file when
  /// it is missing, truncated or of another format.
  static std::unique_ptr<NavMesh> load(const std::filesystem::path& file);
  ~NavMesh();
  NavMesh(const NavMesh&) = delete;
  NavMesh& operator=(const NavMesh&) = delete;

  /// Writes the navmesh (Habitat .navmesh layout) atomically.
  void save(const std::filesystem::path& file) const;

  /// Nearest point on the navmesh within the box `p` +- `halfExtents`, or
  /// nullopt when there is none. `halfExtents` must be finite, non-negative
  /// and at most queryBounds().sizes().
  std::optional<Vec3f> snapPoint(const Vec3f& p,
                                 const Vec3f& halfExtents = {0.5f, 2.0f, 0.5f}) const;
  /// True when `p` lies on the navmesh: its snapped point is within 0.01 m
  /// horizontally and `maxYDelta` vertically (Habitat is_navigable).
  bool isNavigable(const Vec3f& p, float maxYDelta = 0.5f) const;

  /// Connected component ("island") of the navmesh under `p`, or -1 when `p`
  /// is not navigable. Islands are numbered 0..islandCount()-1 by decreasing
  /// area, so island 0 is the main floor; small islands on furniture tops
  /// have large indices.
  int islandIndex(const Vec3f& p) const;
  int islandCount() const;
  /// Walkable area of one island, m^2.
  float islandArea(int island) const;
  /// Total walkable area, m^2.
  float navigableArea() const;
  /// Number of Detour polygons.
  int polygonCount() const;

  /// Length of the shortest navigable path between the snapped `from` and
  /// `to`, metres; kUnreachable when either is off the navmesh or they are on
  /// different islands. Like Habitat, points are snapped to the nearest
  /// polygon within 2 m horizontally and 4 m vertically, so "off the
  /// navmesh" means farther than that. The length sums the 3-D segments
  /// between the path's corners.
  float geodesicDistance(const Vec3f& from, const Vec3f& to) const;
  /// Corner points of that shortest path, starting at snapped `from` and
  /// ending at snapped `to`; empty when unreachable.
  std::vector<Vec3f> shortestPath(const Vec3f& from, const Vec3f& to) const;

  /// Moves from `from` (on the navmesh) towards `to` along the surface,
  /// sliding along boundaries (Detour moveAlongSurface, Habitat's
  /// try_step). Returns the reached point, at navmesh height.
  Vec3f moveAlongSurface(const Vec3f& from, const Vec3f& to) const;
  /// Same as moveAlongSurface() but without sliding: returns `from` unchanged
  /// if the straight move would be altered (Habitat try_step_no_sliding).
  Vec3f moveNoSliding(const Vec3f& from, const Vec3f& to) const;

  /// Horizontal distance from `p` (snapped as in geodesicDistance()) to the
  /// nearest navmesh boundary (wall), searched up to `maxRadius` metres
  /// (finite, >= 0); maxRadius when no boundary is that close, 0 when there
  /// is no navmesh near `p`.
  float distanceToObstacle(const Vec3f& p, float maxRadius = 2.0f) const;

  /// A uniformly random navigable point (area-weighted), on `island` when
  /// it is >= 0. Uses only raw `rng` output, so a seed gives the same points
  /// with any standard library. Throws std::invalid_argument for an island
  /// outside [-1, islandCount()).
  Vec3f randomPoint(std::mt19937_64& rng, int island = -1) const;

  /// The navmesh polygons as triangles (for maps and debugging).
  std::vector<std::array<Vec3f, 3>> triangles() const;

  /// The parameters it was built with. For loaded files: defaults, except
  /// agent_height, agent_radius and agent_max_climb, which the file
  /// records.
  const NavMeshConfig& config() const;

  /// The union of its tiles' bounds: for a navmesh built here (or by
  /// Habitat) the bounds of the mesh it was built from, with y extended by
  /// about agent_height above the highest vertex.
  const Eigen::AlignedBox3f& bounds() const;
  /// The box query points must lie in: bounds() grown by kPoseMargin
  /// (GeometryCheck.h) on every side.
  const Eigen::AlignedBox3f& queryBounds() const;

 private:
  struct Impl;
  explicit NavMesh(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace vln::sim
