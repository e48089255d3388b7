#include "rollout/WaypointOracle.h"

#include <algorithm>
#include <string>

#include "common/Check.h"
#include "rollout/VectorEnv.h"

namespace vln::rollout {

OracleMode parseOracleMode(std::string_view name, std::string_view option) {
  if (name == "goal") return OracleMode::kGoal;
  if (name == "reference_path") return OracleMode::kReferencePath;
  throw std::invalid_argument(strCat(option, ": unknown expert '", name,
                                     "' (expected goal or reference_path)"));
}

std::string_view oracleModeName(OracleMode mode) {
  return mode == OracleMode::kGoal ? "goal" : "reference_path";
}

// ---------------------------------------------------------------------------
// the follower over waypoints

WaypointOracle::WaypointOracle(const sim::NavMesh& navmesh,
                               const sim::AgentConfig& agent, float goalRadius,
                               std::vector<Vec3f> waypoints)
    : follower_(navmesh, agent, goalRadius), waypoints_(std::move(waypoints)) {
  VLN_CHECK_ARG(!waypoints_.empty(),
                "WaypointOracle: an episode needs at least one waypoint");
  // waypoint 0 is the start: the first leg heads for waypoint 1
  current_ = std::min<int>(1, static_cast<int>(waypoints_.size()) - 1);
}

sim::Action WaypointOracle::next(const sim::AgentState& state) {
  const int last = static_cast<int>(waypoints_.size()) - 1;
  // a leg ends where the follower would stop at its waypoint; the next leg
  // starts from the same state, as the ground truth was generated
  while (current_ < last) {
    const sim::Action action =
        follower_.nextAction(state, waypoints_[static_cast<size_t>(current_)]);
    if (action != sim::Action::kStop) return action;
    ++current_;
  }
  return follower_.nextAction(state, waypoints_[static_cast<size_t>(last)]);
}

std::vector<Vec3f> oracleWaypoints(const data::Episode& episode,
                                   OracleMode mode) {
  if (mode == OracleMode::kReferencePath) {
    VLN_CHECK_ARG(!episode.reference_path.empty(), "episode ",
                  episode.episode_id,
                  ": no reference path for the reference_path oracle");
    return episode.reference_path;
  }
  VLN_CHECK_ARG(!episode.goals.empty(), "episode ", episode.episode_id,
                ": no goal for the oracle (a split without goals, such as "
                "test without ground truth, cannot be run by the oracle)");
  return {episode.goals.front().position};
}

// ---------------------------------------------------------------------------
// the oracle as an agent

OracleAgent::OracleAgent(const sim::AgentConfig& agent, float goalRadius,
                         OracleMode mode, int numEnvs)
    : agent_(agent), goalRadius_(goalRadius), mode_(mode) {
  VLN_CHECK_ARG(numEnvs >= 1, "OracleAgent: numEnvs must be >= 1, got ",
                numEnvs);
  slots_.resize(static_cast<size_t>(numEnvs));
}

OracleAgent::Slot& OracleAgent::slotOf(int env, const char* method) {
  VLN_CHECK_ARG(env >= 0 && env < static_cast<int>(slots_.size()),
                "OracleAgent::", method, "(): environment ", env,
                " out of range [0, ", slots_.size(), ")");
  return slots_[static_cast<size_t>(env)];
}

void OracleAgent::reset(int env, const data::Episode& episode) {
  Slot& slot = slotOf(env, "reset");
  slot.waypoints = oracleWaypoints(episode, mode_);
  slot.oracle.reset();
  slot.started = true;
}

std::vector<sim::Action> OracleAgent::act(VectorEnv& envs,
                                          std::span<const int> active) {
  for (int env : active)
    VLN_CHECK_ARG(slotOf(env, "act").started,
                  "OracleAgent::act(): environment ", env, " was never reset");
  // each environment's oracle on its own navmesh, in parallel (navmesh
  // queries are thread-safe; each slot is written by one thread)
  std::vector<sim::Action> actions(active.size());
  envs.forEach(active, [&](int env) {
    Slot& slot = slots_[static_cast<size_t>(env)];
    if (!slot.oracle)
      slot.oracle.emplace(envs.simulator(env).scene().navmesh(), agent_,
                          goalRadius_, slot.waypoints);
    const size_t k = static_cast<size_t>(
        std::find(active.begin(), active.end(), env) - active.begin());
    actions[k] = slot.oracle->next(envs.state(env).agent);
  });
  return actions;
}

}  // namespace vln::rollout
