#pragma once
// The oracle: VLN-CE's shortest-path follower, used for ground-truth action
// sequences, teacher forcing and DAgger.

#include "sim/Agent.h"
#include "sim/NavMesh.h"

namespace vln::sim {

/// Greedy follower of the navmesh shortest path (Habitat's
/// ShortestPathFollower, "geodesic_path" mode).
class ShortestPathFollower {
 public:
  ShortestPathFollower(const NavMesh& navmesh, const AgentConfig& agent,
                       float goalRadius = 0.5f);

  /// STOP when the geodesic distance to `goal` is within the goal radius;
  /// otherwise MOVE_FORWARD when the direction to the next corner of the
  /// shortest path is within turn_angle of the heading, else the turn that
  /// brings the heading closer to it. Returns STOP when the goal is
  /// unreachable. With look_actions, an action other than STOP is preceded
  /// by the looks that level the camera: LOOK_DOWN while the pitch is above
  /// tilt_angle / 2, LOOK_UP while it is below -tilt_angle / 2 (the follower
  /// never pitches the camera itself). Throws std::invalid_argument when the
  /// heading or pitch is not finite, or a position is not finite or outside
  /// the navmesh's queryBounds().
  Action nextAction(const AgentState& state, const Vec3f& goal) const;

 private:
  // nextAction() for a level camera
  Action pathAction(const AgentState& state, const Vec3f& goal) const;

  const NavMesh& navmesh_;
  AgentConfig agent_;
  float goalRadius_;
};

}  // namespace vln::sim
