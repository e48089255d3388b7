#pragma once
// The agent's discrete actions and how they move it over the navmesh.

#include <array>
#include <string_view>

#include "common/Math.h"
#include "sim/SimConfig.h"

namespace vln::sim {

class NavMesh;

/// VLN-CE's action space; the integer values are those of the dataset files.
enum class Action : int {
  kStop = 0,
  kMoveForward = 1,
  kTurnLeft = 2,
  kTurnRight = 3,
};
inline constexpr int kNumActions = 4;

/// "STOP", "MOVE_FORWARD", "TURN_LEFT", "TURN_RIGHT".
std::string_view actionName(Action action);
/// Action from its integer code; throws std::invalid_argument outside 0..3.
Action actionFromInt(int code);

/// Where the agent stands: feet position on the navmesh and heading (radians,
/// 0 = looking along -Z, positive = counter-clockwise from above).
struct AgentState {
  Vec3f position = Vec3f::Zero();
  float heading = 0.0f;
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
/// walls when allow_sliding; turns change the heading by turn_angle. Throws
/// std::invalid_argument when the heading is not finite or the position is
/// not finite or outside navmesh.queryBounds().
StepResult applyAction(const NavMesh& navmesh, const AgentConfig& config,
                       AgentState& state, Action action);

/// Per-episode bookkeeping on top of the agent state.
struct EpisodeState {
  AgentState agent;
  int steps = 0;          ///< actions taken so far
  bool called_stop = false;
  bool done = false;      ///< STOP called or max_episode_steps reached
  bool last_collided = false;
};

/// Takes one action in an episode: updates the agent, the step count and
/// done (STOP or the step limit). Taking an action when done is a bug.
StepResult stepEpisode(const NavMesh& navmesh, const AgentConfig& agent,
                       const TaskConfig& task, EpisodeState& episode,
                       Action action);

}  // namespace vln::sim
