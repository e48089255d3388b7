#include "sim/Agent.h"

#include <cmath>
#include <optional>
#include <stdexcept>

#include "common/Check.h"
#include "sim/GeometryCheck.h"
#include "sim/NavMesh.h"

namespace vln::sim {

namespace {

// Habitat-Sim's collision test (agent/controls/object_controls.py): it
// compares *squared* lengths of the intended and the filtered move with this
// margin, and only a shorter move counts, because climbing a step or a slope
// legitimately moves the agent farther than intended.
constexpr float kCollisionEpsilon = 1e-5f;

}  // namespace

int numActions(const AgentConfig& config) {
  return config.look_actions ? kNumLookActions : kNumActions;
}

std::string_view actionName(Action action) {
  switch (action) {
    case Action::kStop:
      return "STOP";
    case Action::kMoveForward:
      return "MOVE_FORWARD";
    case Action::kTurnLeft:
      return "TURN_LEFT";
    case Action::kTurnRight:
      return "TURN_RIGHT";
    case Action::kLookUp:
      return "LOOK_UP";
    case Action::kLookDown:
      return "LOOK_DOWN";
    case Action::kTeleport:
      return "TELEPORT";
  }
  // only a cast from an unchecked integer gets here
  VLN_ASSERT(false);
  return {};
}

Action actionFromInt(int code, int numActions) {
  // the size is the caller's action space, not input
  VLN_ASSERT(numActions == kNumActions || numActions == kNumLookActions);
  VLN_CHECK_ARG(code >= 0 && code < numActions,
                "actionFromInt(): action code must be in 0..", numActions - 1,
                ", got ", code);
  return static_cast<Action>(code);
}

namespace {

// the public entries of every step check a pose from a file or a caller
// here, before Detour sees it
void checkAgentPose(const char* who, const NavMesh& navmesh,
                    const AgentState& state) {
  checkPosition(who, "agent position", state.position, navmesh.queryBounds());
  VLN_CHECK_ARG(std::isfinite(state.heading), who,
                ": agent heading must be finite, got ", state.heading);
  VLN_CHECK_ARG(std::isfinite(state.pitch), who,
                ": camera pitch must be finite, got ", state.pitch);
}

// what every step of an episode does after moving the agent: count it,
// remember the collision, end the episode at the step limit
void countStep(const TaskConfig& task, EpisodeState& episode,
               const StepResult& result) {
  ++episode.steps;
  episode.last_collided = result.collided;
  if (episode.steps >= task.max_episode_steps) episode.done = true;
}

}  // namespace

StepResult applyAction(const NavMesh& navmesh, const AgentConfig& config,
                       AgentState& state, Action action) {
  checkAgentPose("applyAction()", navmesh, state);
  StepResult result;
  switch (action) {
    case Action::kStop:
      return result;
    case Action::kTurnLeft:
      state.heading = wrapAngle(state.heading + degToRad(config.turn_angle));
      return result;
    case Action::kTurnRight:
      state.heading = wrapAngle(state.heading - degToRad(config.turn_angle));
      return result;
    case Action::kLookUp:
    case Action::kLookDown: {
      // Habitat's v1 look actions rotate the sensors about their local X
      // axis with no constraint, so repeated looks keep turning; the wrap
      // keeps the same rotation
      VLN_CHECK_ARG(config.look_actions, "applyAction(): ", actionName(action),
                    " needs sim.agent.look_actions (the RxR action space)");
      const float tilt = degToRad(config.tilt_angle);
      state.pitch =
          wrapAngle(state.pitch + (action == Action::kLookUp ? tilt : -tilt));
      return result;
    }
    case Action::kTeleport:
      throw std::invalid_argument(
          "applyAction(): TELEPORT needs a target pose (teleportEpisode(), "
          "rollout::VectorEnv::requestTeleport())");
    case Action::kMoveForward:
      break;
  }
  VLN_ASSERT(action == Action::kMoveForward);

  // the body only yaws, so the intended move is horizontal; the navmesh
  // filter puts the end point back on the surface
  const Vec3f start = state.position;
  const Vec3f target =
      start + config.forward_step_size * headingToForward(state.heading);
  const Vec3f end = config.allow_sliding
                        ? navmesh.moveAlongSurface(start, target)
                        : navmesh.moveNoSliding(start, target);
  const float intended = (target - start).squaredNorm();
  const float moved = (end - start).squaredNorm();
  result.collided = moved + kCollisionEpsilon < intended;
  result.distance = std::sqrt(moved);
  state.position = end;
  return result;
}

StepResult stepEpisode(const NavMesh& navmesh, const AgentConfig& agent,
                       const TaskConfig& task, EpisodeState& episode,
                       Action action) {
  VLN_ASSERT(!episode.done);
  const StepResult result = applyAction(navmesh, agent, episode.agent, action);
  if (action == Action::kStop) {
    episode.called_stop = true;
    episode.done = true;
  }
  countStep(task, episode, result);
  return result;
}

Teleport resolveTeleport(const NavMesh& navmesh, const AgentState& from,
                         const AgentState& target) {
  checkAgentPose("resolveTeleport()", navmesh, from);
  VLN_CHECK_ARG(target.position.allFinite() && std::isfinite(target.heading) &&
                    std::isfinite(target.pitch),
                "resolveTeleport(): target pose must be finite, got (",
                target.position.transpose(), "), heading ", target.heading,
                ", pitch ", target.pitch);
  Teleport out;
  out.end = target;
  out.end.position = from.position;
  // a waypoint predicted beyond the house is a wish the navmesh cannot
  // grant, not an error: it is refused like any non-navigable one
  out.refused = true;
  if (!navmesh.queryBounds().contains(target.position)) return out;
  const std::optional<Vec3f> snapped = navmesh.snapPoint(target.position);
  if (!snapped) return out;
  // the island test keeps the agent on the floor it can walk: a snap onto
  // a table top or a disconnected mezzanine would be a place no walk leads
  const int island = navmesh.islandIndex(from.position);
  if (island < 0 || navmesh.islandIndex(*snapped) != island) return out;
  out.end.position = *snapped;
  out.refused = false;
  return out;
}

StepResult teleportEpisode(const NavMesh& navmesh, const TaskConfig& task,
                           EpisodeState& episode, const AgentState& target) {
  VLN_ASSERT(!episode.done);
  const Teleport teleport = resolveTeleport(navmesh, episode.agent, target);
  StepResult result;
  result.collided = teleport.refused;
  result.distance = (teleport.end.position - episode.agent.position).norm();
  episode.agent = teleport.end;
  countStep(task, episode, result);
  return result;
}

}  // namespace vln::sim
