#include "models/PointNavPolicy.h"

#include "models/Policy.h"

namespace vln::models {
namespace {

// DD-PPO's goal and previous-action embedding widths
// (habitat_baselines PointNavResNetNet: tgt_embeding and
// prev_action_embedding are both 32 wide)
constexpr int64_t kGoalEmbeddingDim = 32;
constexpr int64_t kPrevActionEmbeddingDim = 32;

}  // namespace

PointNavPolicyImpl::PointNavPolicyImpl(const ModelConfig& model,
                                       int64_t hiddenSize, bool useDepth)
    : hiddenSize_(hiddenSize) {
  int64_t inputSize = kGoalEmbeddingDim + kPrevActionEmbeddingDim;
  if (useDepth) {
    depth = register_module("depth", DepthEncoder(model));
    const FeatureShape shape = depthFeatureShape(model);
    depth_fc = register_module("depth_fc",
                               torch::nn::Linear(shape[0] * shape[1] * shape[2],
                                                 model.depth_projection_size));
    inputSize += model.depth_projection_size;
  }
  goal_embedding = register_module(
      "goal_embedding", torch::nn::Linear(kPointGoalDims, kGoalEmbeddingDim));
  // index 0 is "episode start", actions are shifted by one (VLN-CE, DD-PPO)
  prev_action_embedding = register_module(
      "prev_action_embedding",
      torch::nn::Embedding(kNumActions + 1, kPrevActionEmbeddingDim));
  gru = register_module("gru", MaskedGru(inputSize, hiddenSize));
  action =
      register_module("action", torch::nn::Linear(hiddenSize, kNumActions));
  // habitat's CategoricalNet: near-uniform initial action distribution
  torch::NoGradGuard noGrad;
  torch::nn::init::orthogonal_(action->weight, /*gain=*/0.01);
  torch::nn::init::zeros_(action->bias);
}

std::pair<torch::Tensor, torch::Tensor> PointNavPolicyImpl::forward(
    const PointNavInputs& inputs, const torch::Tensor& hidden) {
  TORCH_CHECK(inputs.goal.dim() == 3 && inputs.goal.size(2) == kPointGoalDims,
              "PointNavPolicy::forward(): expected goal [T, B, 3], got ",
              inputs.goal.sizes());
  const int64_t steps = inputs.goal.size(0), batch = inputs.goal.size(1);
  TORCH_CHECK(inputs.prev_actions.sizes() == inputs.not_done.sizes() &&
                  inputs.prev_actions.dim() == 2 &&
                  inputs.prev_actions.size(0) == steps &&
                  inputs.prev_actions.size(1) == batch,
              "PointNavPolicy::forward(): expected prev_actions and not_done "
              "[T, B] = [",
              steps, ", ", batch, "], got ", inputs.prev_actions.sizes(),
              " and ", inputs.not_done.sizes());
  TORCH_CHECK(hidden.dim() == 2 && hidden.size(0) == batch &&
                  hidden.size(1) == hiddenSize_,
              "PointNavPolicy::forward(): expected hidden [", batch, ", ",
              hiddenSize_, "], got ", hidden.sizes());

  std::vector<torch::Tensor> parts;
  if (depth) {
    TORCH_CHECK(
        inputs.depth.defined() && inputs.frame_index.defined() &&
            inputs.frame_index.dim() == 1 &&
            inputs.depth.size(0) == inputs.frame_index.size(0),
        "PointNavPolicy::forward(): expected depth [N, H, W, 1] and "
        "frame_index [N], got ",
        inputs.depth.defined() ? inputs.depth.sizes() : torch::IntArrayRef{},
        " and ",
        inputs.frame_index.defined() ? inputs.frame_index.sizes()
                                     : torch::IntArrayRef{});
    // the CNN runs on the real frames only, then they go to their (t, b)
    const torch::Tensor features =
        torch::relu(depth_fc->forward(depth->forward(inputs.depth).flatten(1)));
    const torch::Tensor placed =
        torch::zeros({steps * batch, features.size(1)}, features.options())
            .index_copy(0, inputs.frame_index, features);
    parts.push_back(placed.view({steps, batch, -1}));
  }
  parts.push_back(goal_embedding->forward(inputs.goal));
  const torch::Tensor prevIndex =
      (inputs.prev_actions + 1) * inputs.not_done.to(torch::kLong);
  parts.push_back(prev_action_embedding->forward(prevIndex));

  auto [out, last] =
      gru->forward(torch::cat(parts, /*dim=*/-1), hidden, inputs.not_done);
  return {action->forward(out), last};
}

torch::Tensor PointNavPolicyImpl::initialHidden(int64_t batch) const {
  return torch::zeros({batch, hiddenSize_},
                      action->weight.options().requires_grad(false));
}

}  // namespace vln::models
