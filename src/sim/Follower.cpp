#include "sim/Follower.h"

#include <cmath>

#include "common/Check.h"

namespace vln::sim {

namespace {

// Corners closer than this (horizontally, metres) to the agent are where it
// already stands; their direction is noise.
constexpr float kCornerReached = 1e-3f;
// Habitat's follower accepts MOVE_FORWARD up to turn_angle plus this margin
// (radians), so that a heading exactly turn_angle away does not oscillate.
constexpr float kAngleEpsilon = 1e-6f;

}  // namespace

ShortestPathFollower::ShortestPathFollower(const NavMesh& navmesh,
                                           const AgentConfig& agent,
                                           float goalRadius)
    : navmesh_(navmesh), agent_(agent), goalRadius_(goalRadius) {
  VLN_CHECK_ARG(goalRadius > 0.0f && std::isfinite(goalRadius),
                "ShortestPathFollower: goal radius must be positive, got ",
                goalRadius);
}

Action ShortestPathFollower::nextAction(const AgentState& state,
                                        const Vec3f& goal) const {
  // the navmesh checks both positions; heading and pitch only steer the
  // choice below, where NaN would pick a turn silently
  VLN_CHECK_ARG(std::isfinite(state.heading) && std::isfinite(state.pitch),
                "ShortestPathFollower::nextAction(): agent heading and pitch "
                "must be finite, got ",
                state.heading, ", ", state.pitch);
  const Action action = pathAction(state, goal);
  if (action == Action::kStop) return action;

  // a pitched camera is levelled before the agent moves on: the look that
  // brings the pitch closer to 0, while one does; a pitch within half a tilt
  // of level is as level as looks can make it
  if (!agent_.look_actions) return action;
  const float pitch = wrapAngle(state.pitch);
  if (std::abs(pitch) <= degToRad(agent_.tilt_angle) / 2.0f + kAngleEpsilon)
    return action;
  return pitch > 0.0f ? Action::kLookDown : Action::kLookUp;
}

Action ShortestPathFollower::pathAction(const AgentState& state,
                                        const Vec3f& goal) const {
  // close enough, or no way there
  const std::vector<Vec3f> path = navmesh_.shortestPath(state.position, goal);
  if (path.empty()) return Action::kStop;
  float remaining = 0.0f;
  for (size_t i = 1; i < path.size(); ++i)
    remaining += (path[i] - path[i - 1]).norm();
  if (remaining <= goalRadius_) return Action::kStop;

  // direction to the first corner the agent is not standing on; Habitat
  // moves forward when there is none
  const Vec3f* corner = nullptr;
  for (const Vec3f& p : path) {
    if (horizontalDistance(p, state.position) > kCornerReached) {
      corner = &p;
      break;
    }
  }
  if (corner == nullptr) return Action::kMoveForward;
  const float desired = forwardToHeading(*corner - state.position);

  // forward when within one turn of it, else the turn that gets closer
  const float turn = degToRad(agent_.turn_angle);
  const float alpha = std::abs(wrapAngle(desired - state.heading));
  if (alpha <= turn + kAngleEpsilon) return Action::kMoveForward;
  const float afterLeft = std::abs(wrapAngle(desired - (state.heading + turn)));
  return afterLeft < alpha ? Action::kTurnLeft : Action::kTurnRight;
}

}  // namespace vln::sim
