#pragma once
// The agent's discrete actions and how they move it over the navmesh.

#include <array>
#include <string_view>

#include "common/Math.h"
#include "sim/SimConfig.h"

namespace vln::sim {

class NavMesh;

/// VLN-CE's actions; the integer values are those of the dataset files and
/// of Habitat's HabitatSimActions. Codes 0..3 are R2R_VLNCE's action space
/// (Habitat's "v0"); RxR_VLNCE adds LOOK_UP and LOOK_DOWN (Habitat's "v1",
/// enabled by AgentConfig::look_actions).
enum class Action : int {
  kStop = 0,
  kMoveForward = 1,
  kTurnLeft = 2,
  kTurnRight = 3,
  kLookUp = 4,
  kLookDown = 5,
  /// Not a low-level action: a waypoint agent's request to be placed at a
  /// pose (teleportEpisode(); rollout::VectorEnv::requestTeleport()). Outside
  /// both action spaces, so actionFromInt() never returns it and no policy
  /// can choose it; recorded as code 6 in episode files.
  kTeleport = 6,
};
/// Size of the R2R_VLNCE action space (codes 0..3).
inline constexpr int kNumActions = 4;
/// Size of the RxR_VLNCE action space, LOOK_UP and LOOK_DOWN included
/// (codes 0..5).
inline constexpr int kNumLookActions = 6;

/// The number of actions `config` allows: kNumLookActions when
/// look_actions, else kNumActions.
int numActions(const AgentConfig& config);

/// "STOP", "MOVE_FORWARD", "TURN_LEFT", "TURN_RIGHT", "LOOK_UP",
/// "LOOK_DOWN", "TELEPORT".
std::string_view actionName(Action action);
/// Action from its integer code in an action space of `numActions` actions
/// (kNumActions or kNumLookActions); throws std::invalid_argument outside
/// 0..numActions-1.
Action actionFromInt(int code, int numActions = kNumActions);

/// Where the agent stands: feet position on the navmesh, heading (radians,
/// 0 = looking along -Z, positive = counter-clockwise from above) and the
/// camera's pitch (radians about the camera's local +X axis, positive looks
/// up, wrapped to (-pi, pi]; 0 = level). The body only yaws: the pitch
/// turns the cameras alone, as Habitat's look actions turn the sensors.
struct AgentState {
  Vec3f position = Vec3f::Zero();
  float heading = 0.0f;
  float pitch = 0.0f;
  bool operator==(const AgentState&) const = default;
};

/// Outcome of one action.
struct StepResult {
  /// True when the agent moved less than intended (blocked by an obstacle):
  /// Habitat's test, squared moved distance + 1e-5 < squared intended one,
  /// so climbing a slope (a longer 3-D move) is not a collision.
  bool collided = false;
  /// Distance actually travelled (3-D), metres.
  float distance = 0.0f;
};

/// Applies `action` to `state` (STOP leaves it unchanged). MOVE_FORWARD
/// moves forward_step_size along the heading over the navmesh, sliding along
/// walls when allow_sliding; turns change the heading by turn_angle;
/// LOOK_UP / LOOK_DOWN add / subtract tilt_angle to the pitch, unclamped
/// like Habitat's v1 look actions (no actuation constraint), wrapped to
/// (-pi, pi]. Throws std::invalid_argument when the heading or pitch is not
/// finite, the position is not finite or outside navmesh.queryBounds(), or
/// a look action is taken without config.look_actions or the action is
/// kTeleport (which needs a target: resolveTeleport()).
StepResult applyAction(const NavMesh& navmesh, const AgentConfig& config,
                       AgentState& state, Action action);

/// Where a teleport of an agent at `from` towards the pose `target` ends.
struct Teleport {
  AgentState end;
  /// The target was refused: the agent stays at from.position.
  bool refused = false;
};

/// Resolves a teleport (a waypoint agent's execution: waypoint_agent.execution
/// teleport): target.position snapped to the navmesh (NavMesh::snapPoint()
/// with its default extents, 0.5 m horizontally, 2 m vertically) when the
/// snapped point lies on the island under from.position; otherwise the
/// teleport is refused and the agent keeps its position (a target outside
/// queryBounds(), with no navmesh near it, or on another island: furniture
/// tops, disconnected floors). Heading and pitch become target's either way,
/// so a refused agent still faces where it wanted to go (as VLN-CE's
/// GoTowardPoint turns an agent that cannot move). Walls between the two
/// points do not matter: a teleport is not a walk. Throws
/// std::invalid_argument when `from` fails applyAction()'s checks or
/// `target` is not finite.
Teleport resolveTeleport(const NavMesh& navmesh, const AgentState& from,
                         const AgentState& target);

/// Per-episode bookkeeping on top of the agent state.
struct EpisodeState {
  AgentState agent;
  int steps = 0;  ///< actions taken so far
  bool called_stop = false;
  bool done = false;  ///< STOP called or max_episode_steps reached
  bool last_collided = false;
};

/// Takes one action in an episode: updates the agent, the step count and
/// done (STOP or the step limit). Taking an action when done is a bug.
StepResult stepEpisode(const NavMesh& navmesh, const AgentConfig& agent,
                       const TaskConfig& task, EpisodeState& episode,
                       Action action);

/// Takes one teleport step in an episode: the agent ends where
/// resolveTeleport() puts it, the step count grows by one like any action
/// and the episode is done at task.max_episode_steps (a teleport never
/// calls STOP). The result's collided is the refusal, distance the straight
/// 3-D distance moved (0 when refused). Teleporting when done is a bug.
StepResult teleportEpisode(const NavMesh& navmesh, const TaskConfig& task,
                           EpisodeState& episode, const AgentState& target);

}  // namespace vln::sim
