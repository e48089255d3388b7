#include "models/Policy.h"

#include <cmath>

#include "common/Check.h"
#include "models/CmaPolicy.h"
#include "models/Seq2SeqPolicy.h"

namespace vln::models {

EncodedInstruction EncodedInstruction::select(const torch::Tensor& rows) const {
  auto pick = [&](const torch::Tensor& t) {
    return t.defined() ? t.index_select(0, rows) : t;
  };
  return {pick(states), pick(keys), pick(mask), pick(summary)};
}

PolicyImpl::PolicyImpl(const ModelConfig& config) : config_(config) {
  config_.validate();
  if (config_.usesRgb()) rgbShape_ = rgbFeatureShape(config_);
  if (config_.usesDepth()) depthShape_ = depthFeatureShape(config_);
  if (config_.usesInstruction())
    instruction_encoder =
        register_module("instruction_encoder", InstructionEncoder(config_));
}

EncodedInstruction PolicyImpl::encodeInstruction(
    const torch::Tensor& instruction) {
  if (!instruction_encoder) return {};
  InstructionStates states = instruction_encoder->forward(instruction);
  // padding stays zero: dropout only scales or zeroes values
  states.states = trainingDropout(states.states);
  states.last = trainingDropout(states.last);
  return prepareInstruction(states);
}

torch::Tensor dropoutWhileTraining(const torch::Tensor& x, double p,
                                   bool training) {
  if (!x.defined() || p <= 0.0 || !training) return x;
  return torch::dropout(x, p, /*train=*/true);
}

torch::Tensor PolicyImpl::trainingDropout(const torch::Tensor& x) {
  return dropoutWhileTraining(x, config_.dropout, is_training());
}

PolicyOutputs PolicyImpl::step(const EncodedInstruction& instruction,
                               const PolicyInputs& inputs,
                               const torch::Tensor& hidden) {
  // one step is a sequence of length 1: the same code path as training
  auto once = [](const torch::Tensor& t) {
    return t.defined() ? t.unsqueeze(0) : t;
  };
  PolicyOutputs out =
      forwardSequence(instruction,
                      {once(inputs.rgb), once(inputs.depth),
                       once(inputs.prev_actions), once(inputs.not_done)},
                      hidden);
  out.logits = out.logits.squeeze(0);
  if (out.progress.defined()) out.progress = out.progress.squeeze(0);
  if (out.instruction_attention.defined())
    out.instruction_attention = out.instruction_attention.squeeze(0);
  return out;
}

torch::Tensor PolicyImpl::initialHidden(int64_t batch) const {
  torch::Tensor any = parameters().front();
  return torch::zeros(
      {batch, config_.recurrentStateRows(), config_.hidden_size},
      any.options().requires_grad(false));
}

void PolicyImpl::setWordEmbeddings(const torch::Tensor& matrix) {
  if (instruction_encoder) instruction_encoder->setWordEmbeddings(matrix);
}

std::pair<int64_t, int64_t> PolicyImpl::checkInputs(
    const PolicyInputs& inputs, const torch::Tensor& hidden) const {
  TORCH_CHECK(inputs.not_done.defined() && inputs.not_done.dim() == 2,
              "Policy::forwardSequence(): expected not_done [T, B], got ",
              inputs.not_done.defined() ? inputs.not_done.sizes()
                                        : torch::IntArrayRef{});
  const int64_t steps = inputs.not_done.size(0);
  const int64_t batch = inputs.not_done.size(1);
  TORCH_CHECK(inputs.prev_actions.defined() &&
                  inputs.prev_actions.sizes() == inputs.not_done.sizes(),
              "Policy::forwardSequence(): expected prev_actions [", steps, ", ",
              batch, "]");
  auto checkFeatures = [&](const torch::Tensor& f, const FeatureShape& shape,
                           const char* name) {
    TORCH_CHECK(f.defined() && f.dim() == 5 && f.size(0) == steps &&
                    f.size(1) == batch && f.size(2) == shape[0] &&
                    f.size(3) == shape[1] && f.size(4) == shape[2],
                "Policy::forwardSequence(): expected ", name, " features [",
                steps, ", ", batch, ", ", shape[0], ", ", shape[1], ", ",
                shape[2], "], got ",
                f.defined() ? f.sizes() : torch::IntArrayRef{});
  };
  if (config_.usesRgb()) checkFeatures(inputs.rgb, rgbShape_, "rgb");
  if (config_.usesDepth()) checkFeatures(inputs.depth, depthShape_, "depth");
  TORCH_CHECK(
      hidden.defined() && hidden.dim() == 3 && hidden.size(0) == batch &&
          hidden.size(1) == config_.recurrentStateRows() &&
          hidden.size(2) == config_.hidden_size,
      "Policy::forwardSequence(): expected hidden [", batch, ", ",
      config_.recurrentStateRows(), ", ", config_.hidden_size, "], got ",
      hidden.defined() ? hidden.sizes() : torch::IntArrayRef{});
  return {steps, batch};
}

torch::Tensor PolicyImpl::prevActionIndex(const PolicyInputs& inputs) {
  return ((inputs.prev_actions + 1) * (inputs.not_done != 0)).to(torch::kInt64);
}

void PolicyImpl::initHeads(torch::nn::Linear& action,
                           torch::nn::Linear* progress) {
  torch::NoGradGuard noGrad;
  torch::nn::init::orthogonal_(action->weight, /*gain=*/0.01);
  torch::nn::init::zeros_(action->bias);
  if (progress != nullptr && *progress) {
    torch::nn::init::kaiming_normal_((*progress)->weight, /*a=*/0,
                                     torch::kFanIn, torch::kTanh);
    torch::nn::init::zeros_((*progress)->bias);
  }
}

std::shared_ptr<PolicyImpl> makePolicy(const ModelConfig& config,
                                       const torch::Tensor& wordEmbeddings) {
  // the low-level policies' RGB attention and export expect the CNN's
  // 4x4 feature map
  VLN_CHECK_ARG(config.rgb_semantic_outputs == 0 || !config.usesRgb(),
                "makePolicy(): model.rgb_semantic_outputs is read by the "
                "waypoint CMA only (trainer.task waypoint_cma); set it to 0 "
                "or model.no_rgb: true");
  std::shared_ptr<PolicyImpl> policy;
  if (config.policy == PolicyType::kCma) {
    policy = std::make_shared<CmaPolicyImpl>(config);
  } else {
    policy = std::make_shared<Seq2SeqPolicyImpl>(config);
  }
  if (wordEmbeddings.defined()) policy->setWordEmbeddings(wordEmbeddings);
  return policy;
}

torch::Device modelDevice(const ModelConfig& config) {
  try {
    return torch::Device(config.device);
  } catch (const c10::Error&) {
    throw std::invalid_argument(strCat("modelDevice(): model.device '",
                                       config.device,
                                       "' is not a torch device"));
  }
}

}  // namespace vln::models
