#include "models/Seq2SeqPolicy.h"

#include "common/Check.h"

namespace vln::models {

Seq2SeqPolicyImpl::Seq2SeqPolicyImpl(const ModelConfig& config)
    : PolicyImpl(config) {
  VLN_CHECK_ARG(config.policy == PolicyType::kSeq2Seq,
                "Seq2SeqPolicy: model.policy must be seq2seq, got ",
                policyName(config.policy));
  int64_t inputSize = 0;
  if (config_.usesInstruction()) inputSize += config_.instruction_hidden_size;
  if (config_.usesDepth()) {
    depth_linear = register_module(
        "depth_linear",
        torch::nn::Linear(depthShape_[0] * depthShape_[1] * depthShape_[2],
                          config_.depth_projection_size));
    inputSize += config_.depth_projection_size;
  }
  if (config_.usesRgb()) {
    rgb_linear = register_module(
        "rgb_linear",
        torch::nn::Linear(rgbShape_[0], config_.rgb_projection_size));
    inputSize += config_.rgb_projection_size;
  }
  if (config_.seq2seq_prev_action) {
    prev_action_embedding = register_module(
        "prev_action_embedding",
        torch::nn::Embedding(config_.num_actions + 1,
                             config_.prev_action_embedding_dim));
    inputSize += config_.prev_action_embedding_dim;
  }
  state_encoder = register_module("state_encoder",
                                  MaskedGru(inputSize, config_.hidden_size));
  action_head = register_module(
      "action_head",
      torch::nn::Linear(config_.hidden_size, config_.num_actions));
  if (config_.progress_monitor)
    progress_monitor = register_module(
        "progress_monitor", torch::nn::Linear(config_.hidden_size, 1));
  initHeads(action_head, &progress_monitor);
}

EncodedInstruction Seq2SeqPolicyImpl::prepareInstruction(
    const InstructionStates& states) {
  EncodedInstruction out;
  out.summary = states.last;
  return out;
}

PolicyOutputs Seq2SeqPolicyImpl::forwardSequence(
    const EncodedInstruction& instruction, const PolicyInputs& inputs,
    const torch::Tensor& hidden) {
  const auto [steps, batch] = checkInputs(inputs, hidden);

  // VLN-CE's input order: instruction, depth, RGB (, previous action)
  std::vector<torch::Tensor> parts;
  if (config_.usesInstruction()) {
    TORCH_CHECK(instruction.summary.defined() &&
                    instruction.summary.dim() == 2 &&
                    instruction.summary.size(0) == batch,
                "Seq2SeqPolicy::forwardSequence(): expected an instruction "
                "summary [",
                batch, ", D]; call encodeInstruction() first");
    parts.push_back(instruction.summary.unsqueeze(0).expand(
        {steps, batch, instruction.summary.size(1)}));
  }
  if (config_.usesDepth())
    parts.push_back(
        torch::relu(depth_linear(trainingDropout(inputs.depth.flatten(2)))));
  if (config_.usesRgb())
    parts.push_back(torch::relu(rgb_linear(
        trainingDropout(inputs.rgb.flatten(3)).mean(/*dim=*/-1))));
  if (prev_action_embedding)
    parts.push_back(prev_action_embedding(prevActionIndex(inputs)));

  auto [states, last] = state_encoder(torch::cat(parts, /*dim=*/-1),
                                      hidden.select(1, 0), inputs.not_done);
  PolicyOutputs out;
  out.logits = action_head(trainingDropout(states));
  if (progress_monitor)
    out.progress = torch::tanh(progress_monitor(states)).squeeze(-1);
  out.hidden = last.unsqueeze(1);
  return out;
}

}  // namespace vln::models
