#pragma once
// Internal to PolicyAgent.cpp and ScriptedPolicyAgent.cpp: the state both
// policy agents keep per environment between act() calls (recurrent state,
// previous action, the episode's own generator) and the steps around one
// policy step that they share, so that both choose and advance alike. Not
// part of the eval API.

#include <torch/torch.h>

#include <cstdint>
#include <memory>
#include <random>
#include <span>
#include <string>
#include <vector>

#include "common/Check.h"
#include "common/Random.h"
#include "data/Episode.h"
#include "eval/Baselines.h"
#include "models/Policy.h"
#include "rollout/PolicyAgent.h"
#include "sim/Agent.h"

namespace vln::rollout {

/// What a policy agent keeps per environment; each agent's EnvState
/// derives from it and adds its instruction.
struct RecurrentEnvState {
  bool started = false;
  torch::Tensor hidden;  ///< [layers, hidden_size]
  int64_t prevAction = 0;
  bool first = true;  ///< not_done = 0 on the episode's first step
  std::mt19937_64 rng;

  /// Starts `episode` from `initialHidden` with no previous action and the
  /// generator of (seed, episode id) (common::episodeSeed()).
  void restart(torch::Tensor initialHidden, uint64_t seed,
               const data::Episode& episode) {
    hidden = std::move(initialHidden);
    prevAction = 0;
    first = true;
    rng.seed(common::episodeSeed(seed, std::to_string(episode.episode_id)));
    started = true;
  }
};

/// `states[env]`; throws std::invalid_argument ("<agent>::<method>():
/// environment <env> out of range ...") when there is none.
template <class State>
State& stateAt(const std::vector<std::unique_ptr<State>>& states, int env,
               const char* agent, const char* method) {
  VLN_CHECK_ARG(env >= 0 && env < static_cast<int>(states.size()), agent,
                "::", method, "(): environment ", env, " out of range [0, ",
                states.size(), ")");
  return *states[static_cast<size_t>(env)];
}

/// The states of the `active` environments of act(), in that order; throws
/// std::invalid_argument naming an environment that was never reset.
template <class State>
std::vector<State*> activeStates(
    const std::vector<std::unique_ptr<State>>& states,
    std::span<const int> active, const char* agent) {
  std::vector<State*> out;
  for (int env : active) {
    State& s = stateAt(states, env, agent, "act");
    VLN_CHECK_ARG(s.started, agent, "::act(): environment ", env,
                  " was never reset");
    out.push_back(&s);
  }
  return out;
}

/// The recurrent inputs of one step for `states`: hidden stacked to
/// [n, layers, hidden_size], previous actions int64 [n] and not_done
/// float [n] (0 on an episode's first step) on `device`.
struct RecurrentInputs {
  torch::Tensor hidden;
  torch::Tensor prevActions;
  torch::Tensor notDone;
};

template <class State>
RecurrentInputs recurrentInputs(const std::vector<State*>& states,
                                torch::Device device) {
  std::vector<torch::Tensor> hidden;
  std::vector<int64_t> prev;
  std::vector<float> notDone;
  for (const State* s : states) {
    hidden.push_back(s->hidden);
    prev.push_back(s->prevAction);
    notDone.push_back(s->first ? 0.0f : 1.0f);
  }
  return {torch::stack(hidden), torch::tensor(prev, torch::kInt64).to(device),
          torch::tensor(notDone, torch::kFloat32).to(device)};
}

/// The action of every state from its row of `logits` (float64 [n,
/// kNumActions] on the CPU, contiguous) by chooseAction() with the
/// episode's generator; then advances the state to `newHidden[k]` with the
/// chosen action as the previous one.
template <class State>
std::vector<sim::Action> chooseAndAdvance(const torch::Tensor& logits,
                                          const torch::Tensor& newHidden,
                                          const std::vector<State*>& states,
                                          bool sample) {
  const double* row = logits.data_ptr<double>();
  std::vector<sim::Action> actions(states.size());
  for (size_t k = 0; k < states.size(); ++k) {
    State& s = *states[k];
    const int chosen =
        chooseAction(std::span<const double>(
                         row + static_cast<int64_t>(k) * models::kNumActions,
                         static_cast<size_t>(models::kNumActions)),
                     sample, s.rng);
    actions[k] = sim::actionFromInt(chosen);
    s.hidden = newHidden[static_cast<int64_t>(k)];
    s.prevAction = chosen;
    s.first = false;
  }
  return actions;
}

}  // namespace vln::rollout
