#include "rollout/ScriptedPolicyAgent.h"

#include <string>

#include "common/Check.h"
#include "rollout/ObservationBatch.h"
#include "rollout/PolicyAgent.h"
#include "rollout/RecurrentState.h"

namespace vln::rollout {

struct ScriptedPolicyAgent::EnvState : EpisodeDraws {
  RecurrentState recurrent;
  std::vector<int64_t> tokens;  // real tokens, capped at the max length
};

ScriptedPolicyAgent::ScriptedPolicyAgent(const std::filesystem::path& file,
                                         int numEnvs, bool sampleActions,
                                         uint64_t seed,
                                         int maxInstructionLength,
                                         const std::string& device)
    : ScriptedPolicyAgent(
          loadExportedArchive(file, device, "ScriptedPolicyAgent"), file,
          numEnvs, sampleActions, seed, maxInstructionLength,
          parseDevice(device, "ScriptedPolicyAgent")) {}

ScriptedPolicyAgent::ScriptedPolicyAgent(torch::jit::Module module,
                                         const std::filesystem::path& file,
                                         int numEnvs, bool sampleActions,
                                         uint64_t seed,
                                         int maxInstructionLength,
                                         torch::Device device)
    : file_(file),
      module_(std::move(module)),
      device_(device),
      sample_(sampleActions),
      seed_(seed),
      maxInstructionLength_(maxInstructionLength) {
  VLN_CHECK_ARG(numEnvs >= 1, "ScriptedPolicyAgent: numEnvs must be >= 1, got ",
                numEnvs);
  VLN_CHECK_ARG(maxInstructionLength >= 1,
                "ScriptedPolicyAgent: dataset.max_instruction_length must be "
                ">= 1, got ",
                maxInstructionLength);
  config_ = exportedModelConfig(module_, file);
  // a waypoint policy (models::exportWaypointPolicy()) takes panoramas and
  // candidate waypoints, not one view, and chooses a waypoint
  VLN_CHECK_ARG(!module_.hasattr("num_views"), "ScriptedPolicyAgent: '",
                file.string(),
                "' is a waypoint policy export (it chooses among candidate "
                "waypoints): run it with rollout::ScriptedWaypointModel "
                "(eval does)");
  checkRunsOnObservations(module_, config_, file, "ScriptedPolicyAgent");
  states_.resize(static_cast<size_t>(numEnvs));
}

ScriptedPolicyAgent::~ScriptedPolicyAgent() = default;

void ScriptedPolicyAgent::reset(int env, const data::Episode& episode) {
  EnvState& s = stateAt(states_, env, "ScriptedPolicyAgent", "reset");
  // the archive re-encodes the instruction at every call
  s.tokens = archiveTokens(episode, config_, maxInstructionLength_,
                           "ScriptedPolicyAgent");
  s.recurrent.restart(
      torch::zeros({config_.recurrentStateRows(), config_.hidden_size},
                   torch::TensorOptions(device_).dtype(torch::kFloat32)));
  s.restart(seed_, episode);
}

std::vector<sim::Action> ScriptedPolicyAgent::act(VectorEnv& envs,
                                                  std::span<const int> active) {
  const auto n = static_cast<int64_t>(active.size());
  if (n == 0) return {};
  checkStarted(states_, active, "ScriptedPolicyAgent");
  std::vector<EnvState*> states;
  std::vector<RecurrentState*> recurrent;
  for (int env : active) {
    states.push_back(&states_[static_cast<size_t>(env)]);
    recurrent.push_back(&states.back()->recurrent);
  }
  torch::NoGradGuard noGrad;

  // raw observations; ablated modalities get a placeholder the archive
  // ignores
  const ObservationBatch obs = batchObservations(envs, active, config_);
  const torch::Tensor placeholder =
      torch::zeros({n}, torch::TensorOptions(device_));
  const torch::Tensor rgb =
      obs.rgb.defined() ? obs.rgb.to(device_) : placeholder;
  const torch::Tensor depth =
      obs.depth.defined() ? obs.depth.to(device_) : placeholder;

  std::vector<const std::vector<int64_t>*> rows;
  for (const EnvState* s : states) rows.push_back(&s->tokens);
  const torch::Tensor tokens = tokenBatch(rows, config_);

  const RecurrentInputs inputs = recurrentInputs(recurrent, device_);
  const c10::IValue output =
      module_.forward({rgb, depth, tokens.to(device_), inputs.prevActions,
                       inputs.notDone, inputs.hidden});
  const auto tuple = output.toTuple();
  VLN_CHECK_ARG(tuple->elements().size() == 3, "ScriptedPolicyAgent: '",
                file_.string(), "' forward returned ", tuple->elements().size(),
                " values, expected 3");
  const torch::Tensor logits = tuple->elements()[0]
                                   .toTensor()
                                   .to(torch::kCPU, torch::kFloat64)
                                   .contiguous();
  const torch::Tensor newHidden = tuple->elements()[2].toTensor();
  VLN_CHECK_ARG(logits.dim() == 2 && logits.size(0) == n &&
                    logits.size(1) == config_.num_actions,
                "ScriptedPolicyAgent: '", file_.string(),
                "' forward returned logits ", logits.sizes(), ", expected [", n,
                ", ", config_.num_actions, "] (model.num_actions)");

  // the same choice rule as PolicyAgent
  std::vector<sim::Action> actions;
  for (int64_t k = 0; k < n; ++k) {
    EnvState& s = *states[static_cast<size_t>(k)];
    const int chosen = chooseRow(logits, k, sample_, s.rng);
    s.recurrent.advance(newHidden[k]);
    s.recurrent.prevAction = chosen;
    actions.push_back(sim::actionFromInt(chosen, config_.num_actions));
  }
  return actions;
}

}  // namespace vln::rollout
