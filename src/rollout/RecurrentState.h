#pragma once
// The state a recurrent policy keeps in one environment between steps, and
// the bookkeeping both policy agents (PolicyAgent.h for a policy in memory,
// ScriptedPolicyAgent.h for a TorchScript export) share, so that both step,
// choose and advance alike.

#include <ATen/core/Tensor.h>
#include <c10/core/Device.h>

#include <cstdint>
#include <memory>
#include <random>
#include <span>
#include <vector>

#include "common/Check.h"
#include "common/Random.h"
#include "data/Episode.h"

namespace vln::rollout {

/// A recurrent policy's state in one environment between two steps.
struct RecurrentState {
  at::Tensor hidden;  ///< [layers, hidden_size]
  int64_t prevAction =
      0;              ///< the action taken at the last step (0 at the start)
  bool first = true;  ///< not_done = 0 on the episode's first step

  /// Starts an episode from `initialHidden` with no previous action.
  void restart(at::Tensor initialHidden) {
    hidden = std::move(initialHidden);
    prevAction = 0;
    first = true;
  }
  /// After a step: the policy's new hidden state (the previous action is
  /// set once the action taken is known).
  void advance(at::Tensor newHidden) {
    hidden = std::move(newHidden);
    first = false;
  }
};

/// The recurrent inputs of one step of `states`: hidden stacked to
/// [n, layers, hidden_size], previous actions int64 [n] and not_done
/// float [n] (0 on an episode's first step) on `device`.
struct RecurrentInputs {
  at::Tensor hidden;
  at::Tensor prevActions;
  at::Tensor notDone;
};
RecurrentInputs recurrentInputs(std::span<RecurrentState* const> states,
                                c10::Device device);

/// What an agent keeps per environment besides the policy's state: whether
/// it was reset, and the episode's own generator for sampled actions,
/// seeded by (seed, episode id) so that an episode draws the same numbers
/// whichever environment, batch or thread runs it.
struct EpisodeDraws {
  bool started = false;
  std::mt19937_64 rng;

  void restart(uint64_t seed, const data::Episode& episode) {
    rng.seed(common::episodeSeed(seed, std::to_string(episode.episode_id)));
    started = true;
  }
};

/// `states[env]`; throws std::invalid_argument ("<agent>::<method>():
/// environment <env> out of range ...") when there is none.
template <class State>
State& stateAt(std::vector<State>& states, int env, const char* agent,
               const char* method) {
  VLN_CHECK_ARG(env >= 0 && env < static_cast<int>(states.size()), agent,
                "::", method, "(): environment ", env, " out of range [0, ",
                states.size(), ")");
  return states[static_cast<size_t>(env)];
}

/// Throws std::invalid_argument naming an environment of `active` that was
/// never reset (`started` false) or is out of range.
template <class State>
void checkStarted(std::vector<State>& states, std::span<const int> active,
                  const char* agent) {
  for (int env : active)
    VLN_CHECK_ARG(stateAt(states, env, agent, "act").started, agent,
                  "::act(): environment ", env, " was never reset");
}

}  // namespace vln::rollout
