#pragma once
// Anything that chooses actions for a batch of environments: a trained
// policy, an exported TorchScript policy, or a no-learning baseline.

#include <span>
#include <vector>

#include "data/Episode.h"
#include "rollout/Metrics.h"
#include "rollout/VectorEnv.h"
#include "sim/Agent.h"

namespace vln::rollout {

class Agent {
 public:
  virtual ~Agent() = default;
  /// Environment `env` starts `episode` (its first observation is in envs).
  virtual void reset(int env, const data::Episode& episode) = 0;
  /// One action per environment in `active` (in that order), from their
  /// current observations and states in `envs`.
  virtual std::vector<sim::Action> act(VectorEnv& envs,
                                       std::span<const int> active) = 0;
  /// Whether act() reads observations; baselines do not, so rendering can
  /// be skipped for them.
  virtual bool needsObservations() const { return true; }
  /// Whether instructionAttention() will be asked for (reports); agents that
  /// have none ignore it.
  virtual void keepInstructionAttention(bool /*keep*/) {}
  /// The weights the agent's last act() for `env` gave the instruction's
  /// tokens (the CMA's attention; one per token, summing to 1), empty when
  /// it has none or was not asked to keep them.
  virtual std::vector<float> instructionAttention(int /*env*/) const {
    return {};
  }
  /// The waypoint decisions of `env`'s current episode (a waypoint agent's
  /// candidates and choices, for maps); empty for low-level agents.
  virtual std::vector<WaypointChoice> waypointChoices(int /*env*/) const {
    return {};
  }
};

}  // namespace vln::rollout
