#pragma once
// Executing a candidate waypoint (issue 18). Walking (the default): the
// agent turns towards it in task turns (sim.agent.turn_angle) and walks in
// forward steps (sim.agent.forward_step_size) with the navmesh's collisions
// and sliding, as a real robot would; an approach that runs into an
// obstacle ends where the agent got stuck (its consequence, as Hong et al.
// argue). Teleporting (the option they compare): the agent is placed at the
// waypoint in one step, snapped to the navmesh on its island, or stays where
// it is when that is refused (sim::resolveTeleport()). And the oracle that
// labels a panorama's candidates: the one whose execution ends nearest the
// goal by geodesic distance, or STOP.
//
// Both simulate with the environment's own functions (sim::applyAction(),
// sim::resolveTeleport()) on the navmesh, so a planned execution is the one
// the agent will live through (up to the episode's step limit).
// Heading convention: waypoint/WaypointHeatmap.h.

#include <cstdint>
#include <span>
#include <vector>

#include "common/Config.h"
#include "common/Math.h"
#include "sim/Agent.h"
#include "waypoint/WaypointHeatmap.h"

namespace vln::sim {
class NavMesh;
}

namespace vln::waypoint {

/// How a chosen waypoint is executed (waypoint_agent.execution).
enum class Execution {
  kWalk,      ///< planApproach()'s low-level actions
  kTeleport,  ///< one teleport step to teleportTarget()
};

struct ApproachConfig {
  /// A forward step that collides and moves less than this (m) ends the
  /// approach: the agent is stuck against something.
  float blocked_distance = 0.1f;
  /// The oracle STOPs once the agent is this close to the goal (geodesic m).
  float stop_distance = 1.5f;
  /// ... or, within success_distance of the goal, when no candidate's
  /// approach ends at least min_progress (m) closer to it than the agent.
  float success_distance = 3.0f;
  float min_progress = 0.25f;

  void visit(common::ConfigVisitor& v) {
    v.field("blocked_distance", blocked_distance,
            "A forward step that collides and moves less than this ends the "
            "approach (m)",
            common::inRange(0.0, 10.0));
    v.field("stop_distance", stop_distance,
            "The oracle STOPs within this geodesic distance of the goal (m)",
            common::inRange(0.0, 100.0));
    v.field("success_distance", success_distance,
            "... or within this distance when no candidate gets min_progress "
            "closer (m; R2R's success radius)",
            common::inRange(0.0, 100.0));
    v.field("min_progress", min_progress,
            "Progress a candidate must make for the oracle to prefer it over "
            "STOP inside success_distance (m)",
            common::inRange(0.0, 100.0));
  }
  bool operator==(const ApproachConfig&) const = default;
};

/// The low-level actions of one approach and where they leave the agent.
struct Approach {
  std::vector<sim::Action> actions;  ///< turns, then forward steps; no STOP
  sim::AgentState end;               ///< after the last action
  int turns = 0;
  int forward_steps = 0;  ///< taken (the last one may be blocked)
  bool blocked = false;   ///< ended early against an obstacle
};

/// Turns of `agent.turn_angle` nearest to `heading` (radians, relative,
/// counter-clockwise positive): positive = TURN_LEFT count, negative =
/// TURN_RIGHT count; |result| <= 180 / turn_angle (rounded).
int turnsTowards(const sim::AgentConfig& agent, float heading);

/// Plans the approach of the waypoint at relative `heading` (radians) and
/// horizontal `distance` (m) from `start`: turnsTowards() turns, then
/// round(distance / forward_step_size) forward steps (at least one), stopped
/// early by a blocked step (config.blocked_distance). Throws what
/// sim::applyAction() throws for a state off the navmesh's bounds.
Approach planApproach(const sim::NavMesh& navmesh,
                      const sim::AgentConfig& agent,
                      const sim::AgentState& start, float heading,
                      float distance, const ApproachConfig& config);

/// The pose a teleport to the waypoint at relative `heading` (radians) and
/// horizontal `distance` (m) from `start` asks for: fromPolar()'s point (at
/// the agent's height), facing away from `start` along the waypoint's
/// direction (start.heading + heading, wrapped), start's pitch.
sim::AgentState teleportTarget(const sim::AgentState& start, float heading,
                               float distance);

/// Where executing the waypoint at relative `heading` and `distance` from
/// `start` leaves the agent: planApproach()'s end when walking, where
/// sim::resolveTeleport() puts a teleport to teleportTarget() when
/// teleporting.
sim::AgentState executionEnd(const sim::NavMesh& navmesh,
                             const sim::AgentConfig& agent,
                             const sim::AgentState& start, float heading,
                             float distance, const ApproachConfig& config,
                             Execution execution);

/// The oracle's choice among `candidates` and what it was chosen from.
struct OracleVerdict {
  /// -1 for STOP, else the index of the chosen candidate.
  int choice = -1;
  /// Per candidate, the geodesic distance (m) from where its execution ends
  /// to the goal (infinity where that end cannot reach the goal); empty
  /// when the agent was within stop_distance and nothing was planned.
  std::vector<float> end_distances;
};

/// A band around the path an instruction describes: the oracle may prefer
/// the candidates whose execution ends inside it (oracleVerdict()).
struct PathCorridor {
  std::span<const Vec3f> path;  ///< the reference path's points, in order
  float width = 1.0f;           ///< metres from the path's segments
};

/// The distance (m) from `point` to the nearest segment of `path` (to its
/// one point when it has one); infinity for an empty path.
float distanceToPath(const Vec3f& point, std::span<const Vec3f> path);

/// The oracle's verdict for an agent at `state` heading for `goal` (world
/// frame): the candidate whose execution (executionEnd() under `execution`)
/// ends at the smallest geodesic distance to the goal. STOP (-1) when the
/// agent is within config.stop_distance, or within config.success_distance
/// and no candidate ends config.min_progress closer, or when there is no
/// candidate (or none reaches the goal's island) at all.
/// With a `corridor`, only the candidates whose execution ends within
/// corridor->width of its path compete (all of them when none does): the
/// way the words describe, not a shortcut they never mention.
/// end_distances lists every candidate either way.
OracleVerdict oracleVerdict(const sim::NavMesh& navmesh,
                            const sim::AgentConfig& agent,
                            const sim::AgentState& state,
                            std::span<const Candidate> candidates,
                            const Vec3f& goal, const ApproachConfig& config,
                            Execution execution = Execution::kWalk,
                            const PathCorridor* corridor = nullptr);

/// The choices as good as the verdict's within `tolerance` metres, as bits
/// in the policy's coding (bit 0 STOP, bit j + 1 candidate j): the chosen
/// one, and with tolerance > 0 every candidate whose execution ends at most
/// `tolerance` farther from the goal than the chosen one's. A STOP verdict
/// accepts STOP alone. Two candidates that end 0.1 m apart are the same
/// choice for the task; a label that insists on one of them asks the
/// policy to learn the oracle's tie-break. Throws std::invalid_argument for
/// a negative or non-finite tolerance or more than 31 candidates.
uint32_t acceptableChoices(const OracleVerdict& verdict, float tolerance);

/// oracleVerdict(...).choice.
int oracleChoice(const sim::NavMesh& navmesh, const sim::AgentConfig& agent,
                 const sim::AgentState& state,
                 std::span<const Candidate> candidates, const Vec3f& goal,
                 const ApproachConfig& config,
                 Execution execution = Execution::kWalk);

}  // namespace vln::waypoint
