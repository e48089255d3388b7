#include "rollout/PolicyStepper.h"

#include <torch/torch.h>

#include "common/Check.h"
#include "rollout/ObservationBatch.h"
#include "rollout/PolicyAgent.h"

namespace vln::rollout {

RecurrentInputs recurrentInputs(std::span<RecurrentState* const> states,
                                c10::Device device) {
  std::vector<torch::Tensor> hidden;
  std::vector<int64_t> prev;
  std::vector<float> notDone;
  for (const RecurrentState* s : states) {
    hidden.push_back(s->hidden);
    prev.push_back(s->prevAction);
    notDone.push_back(s->first ? 0.0f : 1.0f);
  }
  return {torch::stack(hidden), torch::tensor(prev, torch::kInt64).to(device),
          torch::tensor(notDone, torch::kFloat32).to(device)};
}

struct PolicyStepper::EnvState {
  const data::Episode* episode = nullptr;
  RecurrentState recurrent;
  models::EncodedInstruction instruction;  ///< one row (not kJoint)
  at::Tensor textFeatures;       ///< [1, L, D] on the CPU (text features only)
  std::vector<float> attention;  ///< of the last step, when kept
};

namespace {

// the device of the policy's parameters (config.device when it has none)
torch::Device policyDevice(const models::PolicyImpl& policy) {
  const auto parameters = policy.parameters();
  if (!parameters.empty()) return parameters.front().device();
  return models::modelDevice(policy.config());
}

// rows `k` of defined feature tensors
models::VisualFeatures featureRow(const models::VisualFeatures& features,
                                  int64_t k) {
  models::VisualFeatures row;
  if (features.rgb.defined()) row.rgb = features.rgb.slice(0, k, k + 1);
  if (features.depth.defined()) row.depth = features.depth.slice(0, k, k + 1);
  return row;
}

}  // namespace

PolicyStepper::PolicyStepper(std::shared_ptr<models::PolicyImpl> policy,
                             int numEnvs, int maxInstructionLength,
                             InstructionBatching batching)
    : policy_(std::move(policy)),
      maxInstructionLength_(maxInstructionLength),
      batching_(batching),
      device_(torch::kCPU) {
  VLN_CHECK_ARG(policy_ != nullptr, "PolicyStepper: the policy is null");
  VLN_CHECK_ARG(numEnvs >= 1, "PolicyStepper: numEnvs must be >= 1, got ",
                numEnvs);
  VLN_CHECK_ARG(maxInstructionLength >= 1,
                "PolicyStepper: dataset.max_instruction_length must be >= 1, "
                "got ",
                maxInstructionLength);
  device_ = policyDevice(*policy_);
  for (int i = 0; i < numEnvs; ++i)
    states_.push_back(std::make_unique<EnvState>());
}

PolicyStepper::~PolicyStepper() = default;

void PolicyStepper::start(int env, const data::Episode& episode) {
  VLN_CHECK_ARG(env >= 0 && env < static_cast<int>(states_.size()),
                "PolicyStepper::start(): environment ", env,
                " out of range [0, ", states_.size(), ")");
  EnvState& s = *states_[static_cast<size_t>(env)];
  torch::NoGradGuard noGrad;
  s.episode = &episode;
  // text features are read once per episode and kept for joint batches
  const models::ModelConfig& config = policy_->config();
  s.textFeatures = torch::Tensor();
  if (config.usesInstruction() && config.usesTextFeatures())
    s.textFeatures =
        instructionFeatures(featureSource_, episode, config.text_feature_dim,
                            maxInstructionLength_);
  // alone, so that the encoding never depends on the batch
  s.instruction = {};
  if (batching_ != InstructionBatching::kJoint && config.usesInstruction()) {
    EnvState* one[] = {&s};
    s.instruction = policy_->encodeInstruction(instructionInput(one));
  }
  s.recurrent.restart(policy_->initialHidden(1)[0]);
  s.attention.clear();
}

torch::Tensor PolicyStepper::step(std::span<const int> envs,
                                  const models::VisualFeatures& features) {
  for (int env : envs)
    VLN_CHECK_ARG(env >= 0 && env < static_cast<int>(states_.size()) &&
                      states_[static_cast<size_t>(env)]->episode,
                  "PolicyStepper::step(): environment ", env,
                  " was never started");
  torch::NoGradGuard noGrad;
  if (batching_ != InstructionBatching::kOneByOne)
    return stepTogether(envs, features);
  // one environment at a time: the same numbers whatever runs beside it
  std::vector<torch::Tensor> logits;
  for (size_t k = 0; k < envs.size(); ++k)
    logits.push_back(stepTogether(
        envs.subspan(k, 1), featureRow(features, static_cast<int64_t>(k))));
  return torch::cat(logits);
}

torch::Tensor PolicyStepper::instructionInput(
    std::span<EnvState* const> states) const {
  if (policy_->config().usesTextFeatures()) {
    std::vector<torch::Tensor> rows;
    for (const EnvState* s : states) rows.push_back(s->textFeatures);
    return batchInstructionFeatures(rows).to(device_);
  }
  std::vector<const data::Episode*> episodes;
  for (const EnvState* s : states) episodes.push_back(s->episode);
  return batchInstructions(episodes, maxInstructionLength_).to(device_);
}

torch::Tensor PolicyStepper::stepTogether(
    std::span<const int> envs, const models::VisualFeatures& features) {
  std::vector<RecurrentState*> recurrent;
  std::vector<const models::EncodedInstruction*> rows;
  std::vector<const data::Episode*> episodes;
  std::vector<EnvState*> states;
  for (int env : envs) {
    EnvState& s = *states_[static_cast<size_t>(env)];
    recurrent.push_back(&s.recurrent);
    rows.push_back(&s.instruction);
    episodes.push_back(s.episode);
    states.push_back(&s);
  }
  models::EncodedInstruction instruction;
  if (batching_ == InstructionBatching::kJoint) {
    if (episodes != jointFor_) {
      joint_ = policy_->encodeInstruction(policy_->config().usesInstruction()
                                              ? instructionInput(states)
                                              : torch::Tensor());
      jointFor_ = episodes;
    }
    instruction = joint_;
  } else if (policy_->config().usesInstruction()) {
    instruction = stackInstructions(rows);
  }
  const RecurrentInputs inputs = recurrentInputs(recurrent, device_);
  models::PolicyInputs step;
  step.rgb = features.rgb;
  step.depth = features.depth;
  step.prev_actions = inputs.prevActions;
  step.not_done = inputs.notDone;
  const models::PolicyOutputs out =
      policy_->step(instruction, step, inputs.hidden);
  for (size_t k = 0; k < recurrent.size(); ++k)
    recurrent[k]->advance(out.hidden[static_cast<int64_t>(k)]);
  if (keepAttention_ && out.instruction_attention.defined()) {
    // each row over the episode's own tokens (the mask's true prefix)
    const torch::Tensor weights =
        out.instruction_attention.to(torch::kCPU, torch::kFloat32).contiguous();
    const torch::Tensor lengths =
        instruction.mask.sum(1).to(torch::kCPU, torch::kInt64).contiguous();
    for (size_t k = 0; k < envs.size(); ++k) {
      const int64_t length = lengths[static_cast<int64_t>(k)].item<int64_t>();
      const float* row = weights[static_cast<int64_t>(k)].data_ptr<float>();
      states_[static_cast<size_t>(envs[k])]->attention.assign(row,
                                                              row + length);
    }
  }
  return out.logits;
}

const std::vector<float>& PolicyStepper::instructionAttention(int env) const {
  VLN_CHECK_ARG(env >= 0 && env < static_cast<int>(states_.size()),
                "PolicyStepper::instructionAttention(): environment ", env,
                " out of range [0, ", states_.size(), ")");
  return states_[static_cast<size_t>(env)]->attention;
}

void PolicyStepper::took(int env, int64_t action) {
  VLN_CHECK_ARG(env >= 0 && env < static_cast<int>(states_.size()),
                "PolicyStepper::took(): environment ", env,
                " out of range [0, ", states_.size(), ")");
  states_[static_cast<size_t>(env)]->recurrent.prevAction = action;
}

}  // namespace vln::rollout
