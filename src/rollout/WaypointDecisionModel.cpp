#include "rollout/WaypointDecisionModel.h"

#include <torch/torch.h>

#include <algorithm>

#include "common/Check.h"
#include "rollout/ObservationBatch.h"
#include "rollout/PolicyAgent.h"

namespace vln::rollout {

struct NativeWaypointModel::EnvState {
  // per policy
  std::vector<models::EncodedInstruction> instructions;
  std::vector<torch::Tensor> hiddens;  // each [1, 2, H]
  // with model.clause_tracker: the clause pointer (the clause the last
  // decision read) per policy, and the episode's batchRuleClauses() row
  std::vector<int64_t> clausePointers;
  torch::Tensor clauseOfToken;  // [1, maxInstructionLength]
  // with model.goal_match: the episode's batchGoalLabels() row
  torch::Tensor goalLabels;  // [1, F_rgb]
};

at::Tensor ensembleLogits(std::span<const at::Tensor> memberLogits) {
  VLN_CHECK_ARG(!memberLogits.empty(), "ensembleLogits(): no member");
  torch::Tensor sum;
  for (const at::Tensor& logits : memberLogits) {
    VLN_CHECK_ARG(logits.sizes() == memberLogits.front().sizes(),
                  "ensembleLogits(): members disagree on the shape (",
                  logits.sizes(), " against ", memberLogits.front().sizes(),
                  ")");
    const torch::Tensor p = torch::softmax(logits.to(torch::kFloat64), -1);
    sum = sum.defined() ? sum + p : p;
  }
  return torch::log(sum / static_cast<double>(memberLogits.size()));
}

NativeWaypointModel::NativeWaypointModel(
    std::shared_ptr<models::WaypointCmaPolicyImpl> policy,
    models::ObservationEncoder encoder, models::WaypointPredictor predictor,
    CandidateNms nms, int maxInstructionLength)
    : NativeWaypointModel(
          std::vector<std::shared_ptr<models::WaypointCmaPolicyImpl>>{
              std::move(policy)},
          std::move(encoder), std::move(predictor), nms, maxInstructionLength) {
}

NativeWaypointModel::NativeWaypointModel(
    std::vector<std::shared_ptr<models::WaypointCmaPolicyImpl>> policies,
    models::ObservationEncoder encoder, models::WaypointPredictor predictor,
    CandidateNms nms, int maxInstructionLength)
    : policies_(std::move(policies)),
      encoder_(std::move(encoder)),
      predictor_(std::move(predictor)),
      nms_(nms),
      maxInstructionLength_(maxInstructionLength) {
  VLN_CHECK_ARG(!policies_.empty(), "NativeWaypointModel: no policy");
  for (size_t m = 0; m < policies_.size(); ++m)
    VLN_CHECK_ARG(policies_[m] != nullptr, "NativeWaypointModel: policy ", m,
                  " is null");
  VLN_CHECK_ARG(!encoder_.is_empty(), "NativeWaypointModel: no encoder");
  const models::WaypointCmaPolicyImpl& first = *policies_.front();
  for (size_t m = 1; m < policies_.size(); ++m) {
    const models::WaypointCmaPolicyImpl& member = *policies_[m];
    VLN_CHECK_ARG(
        member.numViews() == first.numViews() &&
            member.config().usesRgb() == first.config().usesRgb() &&
            member.config().usesDepth() == first.config().usesDepth() &&
            member.config().usesInstruction() ==
                first.config().usesInstruction(),
        "NativeWaypointModel: ensemble member ", m, " reads ",
        member.numViews(), " views (rgb ", member.config().usesRgb(),
        ", depth ", member.config().usesDepth(), ", instruction ",
        member.config().usesInstruction(), "), the first ", first.numViews(),
        " (rgb ", first.config().usesRgb(), ", depth ",
        first.config().usesDepth(), ", instruction ",
        first.config().usesInstruction(), ")");
  }
}

NativeWaypointModel::~NativeWaypointModel() = default;

const models::ModelConfig& NativeWaypointModel::config() const {
  return policies_.front()->config();
}

int NativeWaypointModel::numViews() const {
  return static_cast<int>(policies_.front()->numViews());
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
  const data::Episode* one[] = {&episode};
  // the tokens once; each policy encodes them on its own device
  const torch::Tensor tokens = batchInstructions(one, maxInstructionLength_);
  s.instructions.clear();
  s.hiddens.clear();
  s.clausePointers.assign(policies_.size(), 0);
  // the rule's clauses, for the policies with a clause tracker
  if (std::any_of(policies_.begin(), policies_.end(),
                  [](const auto& p) { return p->config().clause_tracker; }))
    s.clauseOfToken = batchRuleClauses(one, maxInstructionLength_);
  if (std::any_of(policies_.begin(), policies_.end(),
                  [](const auto& p) { return p->config().goal_match; }))
    s.goalLabels = batchGoalLabels(one);
  for (const auto& policy : policies_) {
    policy->eval();
    const torch::Device device = policy->view_linear->weight.device();
    s.instructions.push_back(policy->encodeInstruction(tokens.to(device)));
    s.hiddens.push_back(policy->initialHidden(1));
  }
}

PanoramaFeatures NativeWaypointModel::encode(const at::Tensor& rgb,
                                             const at::Tensor& depth) {
  torch::NoGradGuard noGrad;
  const torch::Device device = policies_.front()->view_linear->weight.device();
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

int NativeWaypointModel::clauseRead(int env) const {
  if (!config().clause_tracker || env < 0 ||
      static_cast<size_t>(env) >= states_.size() ||
      states_[static_cast<size_t>(env)]->clausePointers.empty())
    return -1;
  return static_cast<int>(
      states_[static_cast<size_t>(env)]->clausePointers.front());
}

at::Tensor NativeWaypointModel::step(std::span<const int> envs,
                                     const PanoramaFeatures& features,
                                     const at::Tensor& candidates,
                                     const at::Tensor& mask,
                                     const at::Tensor& prev,
                                     const at::Tensor& notDone,
                                     const at::Tensor& textMask) {
  torch::NoGradGuard noGrad;
  for (int env : envs)
    VLN_CHECK_ARG(!state(env).hiddens.empty(),
                  "NativeWaypointModel::step(): "
                  "environment ",
                  env, " was never reset");
  std::vector<at::Tensor> memberLogits;
  for (size_t m = 0; m < policies_.size(); ++m) {
    models::WaypointCmaPolicyImpl& policy = *policies_[m];
    policy.eval();
    const torch::Device device = policy.view_linear->weight.device();
    std::vector<const models::EncodedInstruction*> instructions;
    std::vector<torch::Tensor> hiddens, clauseOfToken, goalLabels;
    std::vector<int64_t> clauseStart;
    for (int env : envs) {
      const EnvState& s = state(env);
      instructions.push_back(&s.instructions[m]);
      hiddens.push_back(s.hiddens[m]);
      clauseOfToken.push_back(s.clauseOfToken);
      goalLabels.push_back(s.goalLabels);
      clauseStart.push_back(s.clausePointers[m]);
    }
    // features from encode() are already there; the waypoint agent's view
    // labels (waypoint_agent.view_labels) come from the CPU
    auto onDevice = [&](const torch::Tensor& t) {
      return t.defined() ? t.to(device) : t;
    };
    models::WaypointPolicyInputs inputs{
        onDevice(features.rgb), onDevice(features.depth), candidates.to(device),
        mask.to(device),        prev.to(device),          notDone.to(device),
        onDevice(textMask)};
    if (policy.config().clause_tracker) {
      inputs.clause_of_token = torch::cat(clauseOfToken, 0).to(device);
      inputs.clause_start = torch::tensor(clauseStart).to(device);
    }
    if (policy.config().goal_match)
      inputs.goal_labels = torch::cat(goalLabels, 0).to(device);
    const models::EncodedInstruction instruction =
        policy.config().usesInstruction() ? stackInstructions(instructions)
                                          : models::EncodedInstruction{};
    const models::WaypointPolicyOutputs out =
        policy.step(instruction, inputs, torch::cat(hiddens, 0));
    for (size_t i = 0; i < envs.size(); ++i) {
      const auto row = static_cast<int64_t>(i);
      state(envs[i]).hiddens[m] = out.hidden.slice(0, row, row + 1).clone();
      if (out.clause_pointer.defined())
        state(envs[i]).clausePointers[m] =
            out.clause_pointer[row].item<int64_t>();
    }
    memberLogits.push_back(
        out.logits.to(torch::kCPU, torch::kFloat64).contiguous());
  }
  // one policy: its logits as they are (a checkpoint's results unchanged)
  if (memberLogits.size() == 1) return memberLogits.front();
  return ensembleLogits(memberLogits);
}

}  // namespace vln::rollout
