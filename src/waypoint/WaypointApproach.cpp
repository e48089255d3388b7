#include "waypoint/WaypointApproach.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "common/Check.h"
#include "sim/NavMesh.h"

namespace vln::waypoint {

int turnsTowards(const sim::AgentConfig& agent, float heading) {
  const float step = agent.turn_angle * kPi / 180.0f;
  return static_cast<int>(std::lround(wrapAngle(heading) / step));
}

Approach planApproach(const sim::NavMesh& navmesh,
                      const sim::AgentConfig& agent,
                      const sim::AgentState& start, float heading,
                      float distance, const ApproachConfig& config) {
  Approach approach;
  approach.end = start;
  const int turns = turnsTowards(agent, heading);
  const sim::Action turn =
      turns >= 0 ? sim::Action::kTurnLeft : sim::Action::kTurnRight;
  for (int i = 0; i < std::abs(turns); ++i) {
    sim::applyAction(navmesh, agent, approach.end, turn);
    approach.actions.push_back(turn);
  }
  approach.turns = std::abs(turns);
  const int forward = std::max(
      1, static_cast<int>(std::lround(distance / agent.forward_step_size)));
  for (int i = 0; i < forward; ++i) {
    const sim::StepResult result = sim::applyAction(
        navmesh, agent, approach.end, sim::Action::kMoveForward);
    approach.actions.push_back(sim::Action::kMoveForward);
    ++approach.forward_steps;
    if (result.collided && result.distance < config.blocked_distance) {
      approach.blocked = true;
      break;
    }
  }
  return approach;
}

sim::AgentState teleportTarget(const sim::AgentState& start, float heading,
                               float distance) {
  sim::AgentState target = start;
  target.position = fromPolar(start, heading, distance);
  target.heading = wrapAngle(start.heading + heading);
  return target;
}

sim::AgentState executionEnd(const sim::NavMesh& navmesh,
                             const sim::AgentConfig& agent,
                             const sim::AgentState& start, float heading,
                             float distance, const ApproachConfig& config,
                             Execution execution) {
  if (execution == Execution::kTeleport)
    return sim::resolveTeleport(navmesh, start,
                                teleportTarget(start, heading, distance))
        .end;
  return planApproach(navmesh, agent, start, heading, distance, config).end;
}

float distanceToPath(const Vec3f& point, std::span<const Vec3f> path) {
  if (path.empty()) return std::numeric_limits<float>::infinity();
  float best = (point - path.front()).norm();
  for (size_t i = 1; i < path.size(); ++i) {
    const Vec3f a = path[i - 1], ab = path[i] - a;
    const float length2 = ab.squaredNorm();
    const float t = length2 > 0.0f
                        ? std::clamp((point - a).dot(ab) / length2, 0.0f, 1.0f)
                        : 0.0f;
    best = std::min(best, (point - (a + t * ab)).norm());
  }
  return best;
}

OracleVerdict oracleVerdict(const sim::NavMesh& navmesh,
                            const sim::AgentConfig& agent,
                            const sim::AgentState& state,
                            std::span<const Candidate> candidates,
                            const Vec3f& goal, const ApproachConfig& config,
                            Execution execution, const PathCorridor* corridor) {
  OracleVerdict verdict;
  const float here = navmesh.geodesicDistance(state.position, goal);
  if (here <= config.stop_distance) return verdict;
  std::vector<bool> inside(candidates.size(), true);
  bool anyInside = false;
  for (size_t i = 0; i < candidates.size(); ++i) {
    const sim::AgentState end =
        executionEnd(navmesh, agent, state, candidates[i].heading,
                     candidates[i].distance, config, execution);
    verdict.end_distances.push_back(
        navmesh.geodesicDistance(end.position, goal));
    if (corridor != nullptr)
      inside[i] =
          distanceToPath(end.position, corridor->path) <= corridor->width;
    anyInside = anyInside || inside[i];
  }
  float bestDistance = std::numeric_limits<float>::infinity();
  for (size_t i = 0; i < candidates.size(); ++i) {
    const float d = verdict.end_distances[i];
    if ((inside[i] || !anyInside) && d < bestDistance) {
      bestDistance = d;
      verdict.choice = static_cast<int>(i);
    }
  }
  // no candidate, or none ends where the goal can be reached (a chosen one
  // has a finite distance: nothing is below infinity)
  if (verdict.choice < 0) return verdict;
  if (here <= config.success_distance &&
      bestDistance > here - config.min_progress)
    verdict.choice = -1;
  return verdict;
}

uint32_t acceptableChoices(const OracleVerdict& verdict, float tolerance) {
  VLN_CHECK_ARG(std::isfinite(tolerance) && tolerance >= 0.0f,
                "acceptableChoices(): tolerance must be finite and >= 0, got ",
                tolerance);
  VLN_CHECK_ARG(verdict.end_distances.size() < 32,
                "acceptableChoices(): ", verdict.end_distances.size(),
                " candidates do not fit 32 bits with STOP");
  if (verdict.choice < 0) return 1u;
  const float limit =
      verdict.end_distances.at(static_cast<size_t>(verdict.choice)) + tolerance;
  uint32_t bits = 1u << (verdict.choice + 1);
  for (size_t j = 0; j < verdict.end_distances.size(); ++j)
    if (verdict.end_distances[j] <= limit) bits |= 1u << (j + 1);
  return bits;
}

int oracleChoice(const sim::NavMesh& navmesh, const sim::AgentConfig& agent,
                 const sim::AgentState& state,
                 std::span<const Candidate> candidates, const Vec3f& goal,
                 const ApproachConfig& config, Execution execution) {
  return oracleVerdict(navmesh, agent, state, candidates, goal, config,
                       execution)
      .choice;
}

}  // namespace vln::waypoint
