#include "rollout/ScriptedPolicyAgent.h"

#include <algorithm>
#include <sstream>
#include <string>

#include "common/Check.h"
#include "common/Config.h"
#include "common/FileIo.h"
#include "common/ZipIntegrity.h"
#include "data/Vocabulary.h"
#include "rollout/ObservationBatch.h"
#include "rollout/PolicyAgent.h"
#include "rollout/RecurrentState.h"

namespace vln::rollout {

struct ScriptedPolicyAgent::EnvState : EpisodeDraws {
  RecurrentState recurrent;
  std::vector<int64_t> tokens;  // real tokens, capped at the max length
};

models::ModelConfig exportedModelConfig(const torch::jit::Module& module,
                                        const std::filesystem::path& file) {
  VLN_CHECK_ARG(module.hasattr("model_config"), "ScriptedPolicyAgent: '",
                file.string(),
                "' has no 'model_config' attribute (not written by "
                "models::exportPolicy?)");
  const c10::IValue value = module.attr("model_config");
  VLN_CHECK_ARG(value.isString(), "ScriptedPolicyAgent: '", file.string(),
                "': attribute 'model_config' is not a string");
  return common::loadConfigText<models::ModelConfig>(
      value.toStringRef(), file.string() + " model_config");
}

ScriptedPolicyAgent::ScriptedPolicyAgent(const std::filesystem::path& file,
                                         int numEnvs, bool sampleActions,
                                         uint64_t seed,
                                         int maxInstructionLength,
                                         const std::string& device)
    : file_(file),
      device_(torch::kCPU),
      sample_(sampleActions),
      seed_(seed),
      maxInstructionLength_(maxInstructionLength) {
  VLN_CHECK_ARG(numEnvs >= 1, "ScriptedPolicyAgent: numEnvs must be >= 1, got ",
                numEnvs);
  VLN_CHECK_ARG(maxInstructionLength >= 1,
                "ScriptedPolicyAgent: dataset.max_instruction_length must be "
                ">= 1, got ",
                maxInstructionLength);
  VLN_CHECK_IO(std::filesystem::is_regular_file(file), "ScriptedPolicyAgent: '",
               file.string(), "' does not exist");
  try {
    device_ = torch::Device(device);
  } catch (const c10::Error&) {
    throw std::invalid_argument(
        strCat("ScriptedPolicyAgent: device '", device, "' cannot be parsed"));
  }
  // checked first: LibTorch reads damaged archives without checking their
  // CRCs, and its TorchScript parser can crash on them
  const std::string bytes = common::readFile(file);
  try {
    common::verifyZipIntegrity(bytes, file.string());
  } catch (const std::runtime_error& error) {
    throw std::runtime_error(strCat("ScriptedPolicyAgent: ", error.what()));
  }
  try {
    std::istringstream in(bytes);
    module_ = torch::jit::load(in, device_);
  } catch (const c10::Error& error) {
    throw std::runtime_error(strCat(
        "ScriptedPolicyAgent: '", file.string(),
        "' is not a TorchScript archive: ", error.what_without_backtrace()));
  } catch (const std::exception& error) {
    throw std::runtime_error(
        strCat("ScriptedPolicyAgent: '", file.string(),
               "' is not a TorchScript archive: ", error.what()));
  }
  module_.eval();
  config_ = exportedModelConfig(module_, file);
  // a waypoint policy (models::exportWaypointPolicy()) takes panoramas and
  // candidate waypoints, not one view, and chooses a waypoint
  VLN_CHECK_ARG(!module_.hasattr("num_views"), "ScriptedPolicyAgent: '",
                file.string(),
                "' is a waypoint policy export (it chooses among candidate "
                "waypoints); evaluate the waypoint_cma run's checkpoints "
                "instead");
  // the agent feeds the archive token ids; text features would need a
  // feature source (PolicyStepper::setInstructionFeatures) here
  VLN_CHECK_ARG(!config_.usesInstruction() || !config_.usesTextFeatures(),
                "ScriptedPolicyAgent: '", file.string(),
                "' reads text features (model.instruction_features: "
                "rxr_text); the scripted agent feeds instruction tokens only");

  // the archive must encode images itself; an export without encoders
  // takes feature maps in forward and cannot run on observations
  auto hasMethod = [&](const char* name) {
    return module_.find_method(name).has_value();
  };
  VLN_CHECK_ARG(!config_.usesRgb() || hasMethod("encode_rgb"),
                "ScriptedPolicyAgent: '", file.string(),
                "' was exported without its RGB encoder (forward takes "
                "features); export it with the encoders");
  VLN_CHECK_ARG(!config_.usesDepth() || hasMethod("encode_depth"),
                "ScriptedPolicyAgent: '", file.string(),
                "' was exported without its depth encoder (forward takes "
                "features); export it with the encoders");
  states_.resize(static_cast<size_t>(numEnvs));
}

ScriptedPolicyAgent::~ScriptedPolicyAgent() = default;

void ScriptedPolicyAgent::reset(int env, const data::Episode& episode) {
  EnvState& s = stateAt(states_, env, "ScriptedPolicyAgent", "reset");
  // the archive re-encodes the instruction at every call; keep its tokens
  // (real ones only: the encoder packs by length, so padding is free)
  s.tokens.clear();
  if (config_.usesInstruction()) {
    const auto& source = episode.instruction.instruction_tokens;
    const int length =
        std::min(maxInstructionLength_, data::unpaddedLength(source));
    VLN_CHECK_ARG(length >= 1, "ScriptedPolicyAgent::reset(): episode ",
                  episode.episode_id, " has no instruction tokens");
    for (int j = 0; j < length; ++j)
      s.tokens.push_back(source[static_cast<size_t>(j)]);
  }
  s.recurrent.restart(
      torch::zeros({config_.numRecurrentLayers(), config_.hidden_size},
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

  // instruction tokens [n, longest] with PAD 0 on the right
  size_t longest = 1;
  for (const EnvState* s : states)
    longest = std::max(longest, s->tokens.size());
  torch::Tensor tokens =
      torch::zeros({n, static_cast<int64_t>(longest)}, torch::kInt64);
  if (!config_.usesInstruction()) tokens.fill_(1);
  for (int64_t k = 0; k < n; ++k) {
    const auto& row = states[static_cast<size_t>(k)]->tokens;
    for (size_t j = 0; j < row.size(); ++j)
      tokens[k][static_cast<int64_t>(j)] = row[j];
  }

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
