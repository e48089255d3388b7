#include "eval/BaselineAgents.h"

#include <string>

#include "common/Check.h"
#include "rollout/WaypointOracle.h"

namespace vln::eval {

BaselineStatistics baselineStatistics(const data::GroundTruth& train,
                                      const sim::AgentConfig& agent,
                                      std::string_view source) {
  VLN_CHECK_ARG(!train.empty(), "baselineStatistics(): ", source,
                " has no ground-truth paths");
  std::vector<std::vector<int>> sequences;
  std::vector<double> lengths;
  sequences.reserve(train.size());
  lengths.reserve(train.size());
  for (const auto& [episodeId, path] : train) {
    VLN_CHECK_ARG(!path.locations.empty(), "baselineStatistics(): ", source,
                  ": episode ", episodeId, ": field 'locations' is empty");
    std::vector<int> codes;
    codes.reserve(path.actions.size());
    for (sim::Action a : path.actions) codes.push_back(static_cast<int>(a));
    sequences.push_back(std::move(codes));
    // the oracle path the agent walks: start, then one point per forward step
    double length = 0.0;
    for (size_t i = 1; i < path.locations.size(); ++i)
      length += (path.locations[i] - path.locations[i - 1]).norm();
    lengths.push_back(length);
  }
  BaselineStatistics stats;
  try {
    stats.distribution = actionDistribution(sequences);
  } catch (const std::invalid_argument& error) {
    throw std::invalid_argument(strCat("baselineStatistics(): ", source, ": ",
                                       error.what()));
  }
  double sum = 0.0;
  for (double length : lengths) sum += length;
  stats.mean_path_length = sum / static_cast<double>(lengths.size());
  stats.forward_steps = handcraftedForwardSteps(lengths, agent.forward_step_size);
  stats.max_turns = handcraftedMaxTurns(agent.turn_angle);
  stats.num_paths = static_cast<int>(lengths.size());
  return stats;
}

BaselineAgentAdapter::BaselineAgentAdapter(std::string_view name,
                                           const BaselineStatistics& stats,
                                           int numEnvs, uint64_t seed)
    : name_(name) {
  VLN_CHECK_ARG(numEnvs >= 1, "BaselineAgentAdapter: numEnvs must be >= 1, ",
                "got ", numEnvs);
  // one agent per environment, all with the same seed: reset() derives the
  // episode's draws from (seed, episode id), not from the environment
  for (int i = 0; i < numEnvs; ++i)
    agents_.push_back(
        makeBaseline(name, stats.distribution, stats.forward_steps,
                     stats.max_turns, seed));
  started_.assign(static_cast<size_t>(numEnvs), false);
}

BaselineAgent& BaselineAgentAdapter::agentOf(int env, const char* method) {
  VLN_CHECK_ARG(env >= 0 && env < static_cast<int>(agents_.size()),
                "BaselineAgentAdapter::", method, "(): environment ", env,
                " out of range [0, ", agents_.size(), ")");
  return *agents_[static_cast<size_t>(env)];
}

const BaselineAgent& BaselineAgentAdapter::agent(int env) const {
  VLN_CHECK_ARG(env >= 0 && env < static_cast<int>(agents_.size()),
                "BaselineAgentAdapter::agent(): environment ", env,
                " out of range [0, ", agents_.size(), ")");
  return *agents_[static_cast<size_t>(env)];
}

void BaselineAgentAdapter::reset(int env, const data::Episode& episode) {
  agentOf(env, "reset").reset(std::to_string(episode.episode_id));
  started_[static_cast<size_t>(env)] = true;
}

std::vector<sim::Action> BaselineAgentAdapter::act(
    rollout::VectorEnv& /*envs*/, std::span<const int> active) {
  std::vector<sim::Action> actions;
  actions.reserve(active.size());
  for (int env : active) {
    BaselineAgent& agent = agentOf(env, "act");
    VLN_CHECK_ARG(started_[static_cast<size_t>(env)],
                  "BaselineAgentAdapter::act(): environment ", env,
                  " was never reset");
    actions.push_back(agent.act());
  }
  return actions;
}

// ---------------------------------------------------------------------------
// the oracle

std::unique_ptr<rollout::Agent> makeOracleAgent(const sim::AgentConfig& agent,
                                                const sim::TaskConfig& task,
                                                const std::string& expert,
                                                int numEnvs) {
  return std::make_unique<rollout::OracleAgent>(
      agent, task.follower_goal_radius,
      rollout::parseOracleMode(expert, "trainer.expert"), numEnvs);
}

void checkOracleSplits(std::span<const data::Split> splits) {
  for (const data::Split& split : splits)
    for (const data::Episode& episode : split.episodes)
      VLN_CHECK_ARG(!episode.goals.empty(), "eval --agent oracle: split '",
                    split.name, "' has no goals (episode ", episode.episode_id,
                    "; a split without ground truth, such as test): the "
                    "oracle needs the goal of every episode");
}

}  // namespace vln::eval
