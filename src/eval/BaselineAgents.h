#pragma once
// The no-learning baselines of paper Table 1 (Baselines.h) as evaluation
// Agents, with their statistics taken from the training split's ground
// truth as VLN-CE derived them: the random agent's action distribution
// (Sec. 5.1: 68% forward, 15% left, 15% right, 2% stop) and the
// hand-crafted agent's forward steps (the mean training path length over the
// forward step size: 37 steps in the paper).

#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "data/GroundTruth.h"
#include "data/Split.h"
#include "eval/Baselines.h"
#include "rollout/Agent.h"
#include "sim/SimConfig.h"

namespace vln::eval {

/// What the baselines learn from the training split.
struct BaselineStatistics {
  /// Frequencies of the ground-truth actions (eval::actionDistribution()).
  ActionDistribution distribution = kPaperActionDistribution;
  /// Mean ground-truth path length, metres: the sum of the 3-D distances
  /// between consecutive `locations` of each path, averaged over paths.
  double mean_path_length = 0.0;
  /// round(mean_path_length / forward step size) (handcraftedForwardSteps()).
  int forward_steps = kPaperHandcraftedForwardSteps;
  /// The hand-crafted agent's largest number of initial turns, from the
  /// agent's turn angle (handcraftedMaxTurns(): 24 for 15 degrees).
  int max_turns = kHandcraftedMaxTurns;
  /// Ground-truth paths the statistics were computed from.
  int num_paths = 0;
};

/// Statistics of a training ground truth for an agent that moves and turns
/// as `agent` says (forward_step_size, turn_angle). Throws
/// std::invalid_argument naming `source` when the ground truth is empty, has
/// no actions, or a path has no locations.
BaselineStatistics baselineStatistics(const data::GroundTruth& train,
                                      const sim::AgentConfig& agent,
                                      std::string_view source = "<ground truth>");

/// Runs one BaselineAgent per environment. reset() re-seeds the
/// environment's agent from (seed, episode id) (Baselines.h), so an
/// episode's actions do not depend on the environment, the batch or the
/// thread it runs in. Reads no observations.
class BaselineAgentAdapter : public rollout::Agent {
 public:
  /// `name` is "random" or "handcrafted" (makeBaseline()); `numEnvs` >= 1.
  BaselineAgentAdapter(std::string_view name, const BaselineStatistics& stats,
                       int numEnvs, uint64_t seed);
  void reset(int env, const data::Episode& episode) override;
  std::vector<sim::Action> act(rollout::VectorEnv& envs,
                               std::span<const int> active) override;
  bool needsObservations() const override { return false; }
  /// "random" or "handcrafted".
  const std::string& name() const { return name_; }
  /// The agent of environment `env` (e.g. to read HandcraftedAgent::turns()).
  const BaselineAgent& agent(int env) const;

 private:
  BaselineAgent& agentOf(int env, const char* method);
  std::string name_;
  std::vector<std::unique_ptr<BaselineAgent>> agents_;
  std::vector<bool> started_;
};

/// The oracle as `eval --agent oracle` runs it: rollout::OracleAgent
/// following trainer.expert `expert` ("goal", VLN-CE's shortest path to the
/// goal, by default; or "reference_path"), stopping within
/// task.follower_goal_radius, on `numEnvs` environments. Throws
/// std::invalid_argument naming trainer.expert for another expert.
std::unique_ptr<rollout::Agent> makeOracleAgent(const sim::AgentConfig& agent,
                                                const sim::TaskConfig& task,
                                                const std::string& expert,
                                                int numEnvs);

/// Throws std::invalid_argument naming the split and the episode when an
/// episode of `splits` has no goal (a split without ground truth, such as
/// test): the oracle needs every episode's goal.
void checkOracleSplits(std::span<const data::Split> splits);

}  // namespace vln::eval
