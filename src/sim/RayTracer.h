#pragma once
// Ray queries against a scene's triangles with Embree 3. Built once per
// scene; all const methods are thread-safe.

#include <memory>
#include <optional>
#include <span>

#include "common/Math.h"
#include "sim/Mesh.h"

namespace vln::sim {

/// The first surface a ray meets.
struct RayHit {
  float distance = 0.0f;   ///< along the (normalised) ray, metres
  Vec3f point = Vec3f::Zero();
  Vec3f normal = Vec3f::Zero();  ///< geometric normal, unit, facing the ray
  int triangle = -1;
  int object = -1;         ///< semantic object id or -1
};

/// An Embree BVH over a TriangleMesh (which must outlive it).
class RayTracer {
 public:
  /// Builds the BVH. Throws std::invalid_argument when the mesh is invalid
  /// or fails checkSceneGeometry() (GeometryCheck.h), std::runtime_error if
  /// Embree reports an error.
  explicit RayTracer(const TriangleMesh& mesh);
  ~RayTracer();
  RayTracer(const RayTracer&) = delete;
  RayTracer& operator=(const RayTracer&) = delete;

  /// Nearest hit along `origin` + t * `direction` for t in (0, maxDistance].
  /// Throws std::invalid_argument unless the direction is finite and
  /// non-zero, maxDistance >= 0 (infinity allowed) and the origin finite and
  /// within the mesh's bounds grown by kPoseMargin (GeometryCheck.h).
  std::optional<RayHit> cast(const Vec3f& origin, const Vec3f& direction,
                             float maxDistance = 1e30f) const;
  /// True when nothing blocks the segment from `a` to `b`; both points
  /// must lie where cast() accepts an origin.
  bool visible(const Vec3f& a, const Vec3f& b) const;

  /// The mesh it was built from.
  const TriangleMesh& mesh() const;
  /// Opaque Embree scene handle (RTCScene) for renderers in this module.
  void* embreeScene() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace vln::sim
