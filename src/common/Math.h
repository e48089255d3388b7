#pragma once
// Geometry conventions shared by every module, identical to Habitat's so that
// R2R_VLNCE files and MP3D scenes need no conversion:
//  - world frame: +Y is up, metres;
//  - an agent with heading 0 looks along -Z; a positive heading is a
//    counter-clockwise rotation about +Y seen from above, so TURN_LEFT adds to
//    the heading and TURN_RIGHT subtracts;
//  - rotations in episode files are yaw-only quaternions stored [x, y, z, w].

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <array>
#include <cmath>
#include <numbers>

namespace vln {

using Vec2f = Eigen::Vector2f;
using Vec3f = Eigen::Vector3f;
using Vec3d = Eigen::Vector3d;

inline constexpr float kPi = std::numbers::pi_v<float>;

/// Degrees to radians.
inline float degToRad(float degrees) { return degrees * kPi / 180.0f; }
/// Radians to degrees.
inline float radToDeg(float radians) { return radians * 180.0f / kPi; }

/// Wraps an angle to (-pi, pi].
inline float wrapAngle(float radians) {
  float a = std::remainder(radians, 2.0f * kPi);
  return a <= -kPi ? a + 2.0f * kPi : a;
}

/// Unit forward vector (world frame, horizontal) of an agent with `heading`
/// radians: heading 0 looks along -Z.
inline Vec3f headingToForward(float heading) {
  return {-std::sin(heading), 0.0f, -std::cos(heading)};
}

/// Heading (radians) whose forward vector points along the horizontal part
/// of `direction`.
inline float forwardToHeading(const Vec3f& direction) {
  return std::atan2(-direction.x(), -direction.z());
}

/// Yaw-only rotation as an [x, y, z, w] quaternion (Habitat's file layout).
inline std::array<float, 4> headingToQuaternion(float heading) {
  return {0.0f, std::sin(heading / 2.0f), 0.0f, std::cos(heading / 2.0f)};
}

/// Heading of an [x, y, z, w] quaternion, projected onto the yaw axis.
inline float quaternionToHeading(const std::array<float, 4>& xyzw) {
  Eigen::Quaternionf q(xyzw[3], xyzw[0], xyzw[1], xyzw[2]);
  if (q.norm() < 1e-8f) return 0.0f;
  q.normalize();
  return forwardToHeading(q * Vec3f(0.0f, 0.0f, -1.0f));
}

/// Distance between the horizontal (x, z) projections of two points.
inline float horizontalDistance(const Vec3f& a, const Vec3f& b) {
  return std::hypot(a.x() - b.x(), a.z() - b.z());
}

}  // namespace vln
