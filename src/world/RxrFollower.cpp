#include "world/RxrFollower.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "common/Check.h"
#include "sim/Follower.h"

namespace vln::world {

namespace {

using sim::Action;

// A reached waypoint may lie this much beyond the goal radius (float noise
// of the geodesic query; data::checkNavigability() allows the same).
constexpr float kReachSlack = 1e-4f;

// The detours tried when a forward step is blocked, shortest first.
const std::array<std::vector<Action>, 4>& detours() {
  static const std::array<std::vector<Action>, 4> kDetours = {{
      {Action::kTurnLeft, Action::kMoveForward},
      {Action::kTurnRight, Action::kMoveForward},
      {Action::kTurnLeft, Action::kTurnLeft, Action::kMoveForward},
      {Action::kTurnRight, Action::kTurnRight, Action::kMoveForward},
  }};
  return kDetours;
}

}  // namespace

data::NavigabilityResult followRxrWalk(const sim::NavMesh& navmesh,
                                       const sim::AgentConfig& agent,
                                       const data::TransferConfig& config,
                                       const std::vector<Vec3f>& waypoints,
                                       float startHeading) {
  VLN_CHECK_ARG(waypoints.size() >= 2,
                "followRxrWalk(): a walk needs at least two waypoints, got ",
                waypoints.size());
  data::NavigabilityResult result;
  result.geodesic_distance =
      navmesh.geodesicDistance(waypoints.front(), waypoints.back());
  const sim::ShortestPathFollower follower(navmesh, agent,
                                           config.follower_goal_radius);
  data::GroundTruthPath path;
  sim::AgentState state{waypoints.front(), wrapAngle(startHeading)};
  path.locations.push_back(state.position);

  // takes `action` for real and records it
  const auto take = [&](Action action) {
    const Vec3f before = state.position;
    sim::applyAction(navmesh, agent, state, action);
    path.actions.push_back(action);
    if (action == Action::kMoveForward) ++path.forward_steps;
    if (state.position != before) path.locations.push_back(state.position);
  };

  for (size_t leg = 0; leg + 1 < waypoints.size(); ++leg) {
    // the A* path to the next waypoint must exist, without a long way round
    const Vec3f& target = waypoints[leg + 1];
    const float geodesic = navmesh.geodesicDistance(state.position, target);
    if (!std::isfinite(geodesic)) {
      result.failure = data::NavigabilityFailure::kNoPath;
      result.failed_index = static_cast<int>(leg);
      return result;
    }
    if (config.max_leg_detour > 0.0f) {
      const float straight = (target - waypoints[leg]).norm();
      const float around = navmesh.geodesicDistance(waypoints[leg], target);
      if (around > config.max_leg_detour * std::max(straight, 1.0f)) {
        result.failure = data::NavigabilityFailure::kDetour;
        result.failed_index = static_cast<int>(leg);
        return result;
      }
    }

    // follow it; a blocked forward step becomes the best unblocked detour
    const int cap =
        config.leg_base_steps +
        static_cast<int>(std::ceil(config.leg_steps_per_meter * geodesic));
    const size_t legStart = path.actions.size();
    bool stopped = false;
    while (static_cast<int>(path.actions.size() - legStart) < cap) {
      const Action action = follower.nextAction(state, target);
      if (action == Action::kStop) {
        stopped = true;
        break;
      }
      if (action != Action::kMoveForward) {
        take(action);
        continue;
      }
      sim::AgentState trial = state;
      if (!sim::applyAction(navmesh, agent, trial, action).collided) {
        take(action);
        continue;
      }
      const std::vector<Action>* best = nullptr;
      float bestDistance = std::numeric_limits<float>::infinity();
      for (const std::vector<Action>& detour : detours()) {
        sim::AgentState s = state;
        bool collided = false;
        for (const Action a : detour)
          collided = sim::applyAction(navmesh, agent, s, a).collided;
        if (collided) continue;
        const float d = navmesh.geodesicDistance(s.position, target);
        if (d < bestDistance) {
          bestDistance = d;
          best = &detour;
        }
      }
      if (best == nullptr) {
        take(action);  // nothing better: the blocked step, until the cap
        continue;
      }
      for (const Action a : *best) take(a);
    }

    // the follower also stops when the goal became unreachable, so the
    // remaining distance decides
    const float remaining = navmesh.geodesicDistance(state.position, target);
    if (!stopped || !(remaining <= config.follower_goal_radius + kReachSlack)) {
      result.failure = data::NavigabilityFailure::kNotReached;
      result.failed_index = static_cast<int>(leg);
      return result;
    }
  }

  path.actions.push_back(Action::kStop);
  result.ground_truth = std::move(path);
  return result;
}

}  // namespace vln::world
