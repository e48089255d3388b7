#include "rollout/WaypointDecisionModel.h"

#include <torch/torch.h>

#include "common/Check.h"
#include "rollout/ObservationBatch.h"
#include "rollout/PolicyAgent.h"

namespace vln::rollout {

struct NativeWaypointModel::EnvState {
  models::EncodedInstruction instruction;
  torch::Tensor hidden;  // [1, 2, H]
};

NativeWaypointModel::NativeWaypointModel(
    std::shared_ptr<models::WaypointCmaPolicyImpl> policy,
    models::ObservationEncoder encoder, models::WaypointPredictor predictor,
    CandidateNms nms, int maxInstructionLength)
    : policy_(std::move(policy)),
      encoder_(std::move(encoder)),
      predictor_(std::move(predictor)),
      nms_(nms),
      maxInstructionLength_(maxInstructionLength) {
  VLN_CHECK_ARG(policy_ != nullptr, "NativeWaypointModel: no policy");
  VLN_CHECK_ARG(!encoder_.is_empty(), "NativeWaypointModel: no encoder");
}

NativeWaypointModel::~NativeWaypointModel() = default;

const models::ModelConfig& NativeWaypointModel::config() const {
  return policy_->config();
}

int NativeWaypointModel::numViews() const {
  return static_cast<int>(policy_->numViews());
}

NativeWaypointModel::EnvState& NativeWaypointModel::state(int env) {
  VLN_CHECK_ARG(env >= 0, "NativeWaypointModel: environment ", env,
                " out of range");
  while (states_.size() <= static_cast<size_t>(env))
    states_.push_back(std::make_unique<EnvState>());
  return *states_[static_cast<size_t>(env)];
}

void NativeWaypointModel::reset(int env, const data::Episode& episode) {
  EnvState& s = state(env);
  torch::NoGradGuard noGrad;
  policy_->eval();
  const data::Episode* one[] = {&episode};
  const torch::Device device = policy_->view_linear->weight.device();
  s.instruction = policy_->encodeInstruction(
      batchInstructions(one, maxInstructionLength_).to(device));
  s.hidden = policy_->initialHidden(1);
}

PanoramaFeatures NativeWaypointModel::encode(const at::Tensor& rgb,
                                             const at::Tensor& depth) {
  torch::NoGradGuard noGrad;
  const torch::Device device = policy_->view_linear->weight.device();
  const torch::Tensor anyInput = rgb.defined() ? rgb : depth;
  const int64_t n = anyInput.size(0), views = anyInput.size(1);
  encoder_->eval();
  const models::VisualFeatures features =
      encoder_->forward(rgb.defined() ? rgb.to(device) : rgb,
                        depth.defined() ? depth.to(device) : depth);
  PanoramaFeatures out;
  if (features.rgb.defined()) out.rgb = features.rgb.reshape({n, views, -1});
  if (features.depth.defined())
    out.depth = features.depth.reshape({n, views, -1});
  return out;
}

std::vector<std::vector<waypoint::Candidate>> NativeWaypointModel::propose(
    const PanoramaFeatures& features) {
  VLN_CHECK_ARG(proposes(), "NativeWaypointModel::propose(): no predictor");
  torch::NoGradGuard noGrad;
  predictor_->eval();
  const torch::Tensor probabilities =
      models::waypointProbabilities(
          predictor_->forward(features.depth, features.rgb))
          .to(torch::kCPU)
          .contiguous();
  std::vector<std::vector<waypoint::Candidate>> out;
  for (int64_t i = 0; i < probabilities.size(0); ++i) {
    const float* row = probabilities[i].data_ptr<float>();
    out.push_back(waypoint::heatmapNms(
        std::span<const float>(row, waypoint::kHeatmapSize),
        nms_.max_candidates, nms_.heading_radius, nms_.distance_radius,
        nms_.min_score));
  }
  return out;
}

at::Tensor NativeWaypointModel::step(std::span<const int> envs,
                                     const PanoramaFeatures& features,
                                     const at::Tensor& candidates,
                                     const at::Tensor& mask,
                                     const at::Tensor& prev,
                                     const at::Tensor& notDone) {
  torch::NoGradGuard noGrad;
  policy_->eval();
  const torch::Device device = policy_->view_linear->weight.device();
  std::vector<const models::EncodedInstruction*> instructions;
  std::vector<torch::Tensor> hiddens;
  for (int env : envs) {
    const EnvState& s = state(env);
    VLN_CHECK_ARG(s.hidden.defined(), "NativeWaypointModel::step(): "
                  "environment ", env, " was never reset");
    instructions.push_back(&s.instruction);
    hiddens.push_back(s.hidden);
  }
  models::WaypointPolicyInputs inputs{features.rgb,         features.depth,
                                      candidates.to(device), mask.to(device),
                                      prev.to(device),       notDone.to(device)};
  const models::EncodedInstruction instruction =
      policy_->config().usesInstruction() ? stackInstructions(instructions)
                                          : models::EncodedInstruction{};
  const models::WaypointPolicyOutputs out =
      policy_->step(instruction, inputs, torch::cat(hiddens, 0));
  for (size_t i = 0; i < envs.size(); ++i) {
    const auto row = static_cast<int64_t>(i);
    state(envs[i]).hidden = out.hidden.slice(0, row, row + 1).clone();
  }
  return out.logits.to(torch::kCPU, torch::kFloat64).contiguous();
}

}  // namespace vln::rollout
