#include "models/Loss.h"

#include <torch/torch.h>

namespace vln::models {

torch::Tensor inflectionWeights(const torch::Tensor& actions,
                                const torch::Tensor& valid, double coef) {
  TORCH_CHECK(actions.dim() == 2 && valid.sizes() == actions.sizes(),
              "inflectionWeights(): expected actions and valid [T, B], got ",
              actions.sizes(), " and ", valid.sizes());
  torch::Tensor changed = torch::ones_like(actions, torch::kBool);
  if (actions.size(0) > 1)
    changed.slice(0, 1).copy_(actions.slice(0, 1) != actions.slice(0, 0, -1));
  const torch::Tensor weights =
      torch::where(changed, torch::full_like(actions, coef, torch::kFloat32),
                   torch::ones_like(actions, torch::kFloat32));
  return weights * valid.to(torch::kFloat32);
}

torch::Tensor weightedActionLoss(const torch::Tensor& logits,
                                 const torch::Tensor& actions,
                                 const torch::Tensor& weights) {
  TORCH_CHECK(logits.dim() == 3 && actions.dim() == 2 &&
                  logits.size(0) == actions.size(0) &&
                  logits.size(1) == actions.size(1) &&
                  weights.sizes() == actions.sizes(),
              "weightedActionLoss(): expected logits [T, B, A], actions and "
              "weights [T, B], got ",
              logits.sizes(), ", ", actions.sizes(), ", ", weights.sizes());
  // padded steps may hold any action id; their weight is zero
  const torch::Tensor safeActions =
      torch::where(weights > 0, actions, torch::zeros_like(actions));
  const torch::Tensor ce = -torch::log_softmax(logits, /*dim=*/-1)
                                .gather(-1, safeActions.unsqueeze(-1))
                                .squeeze(-1);  // [T, B]
  const torch::Tensor perEpisode =
      (weights * ce).sum(0) / weights.sum(0).clamp_min(1e-12);
  return perEpisode.mean();
}

torch::Tensor progressLoss(const torch::Tensor& progress,
                           const torch::Tensor& target,
                           const torch::Tensor& valid) {
  TORCH_CHECK(
      progress.sizes() == target.sizes() && valid.sizes() == target.sizes(),
      "progressLoss(): expected progress, target and valid of one "
      "shape, got ",
      progress.sizes(), ", ", target.sizes(), ", ", valid.sizes());
  const torch::Tensor mask = valid.to(progress.scalar_type());
  return ((progress - target).square() * mask).sum() /
         mask.sum().clamp_min(1.0);
}

torch::Tensor instructionContrast(const torch::Tensor& ownLogits,
                                  const torch::Tensor& swappedLogits,
                                  const torch::Tensor& labels,
                                  const torch::Tensor& valid) {
  TORCH_CHECK(ownLogits.sizes() == swappedLogits.sizes() &&
                  ownLogits.dim() == labels.dim() + 1 &&
                  labels.sizes() == valid.sizes() &&
                  ownLogits.sizes().slice(0, labels.dim()) == labels.sizes(),
              "instructionContrast(): expected logits [..., A] of one shape "
              "and labels and valid of their leading shape, got ",
              ownLogits.sizes(), ", ", swappedLogits.sizes(), ", ",
              labels.sizes(), ", ", valid.sizes());
  const torch::Tensor index =
      torch::where(valid, labels, torch::zeros_like(labels)).unsqueeze(-1);
  const torch::Tensor own =
      torch::log_softmax(ownLogits, -1).gather(-1, index).squeeze(-1);
  const torch::Tensor other =
      torch::log_softmax(swappedLogits, -1).gather(-1, index).squeeze(-1);
  const torch::Tensor mask = valid.to(ownLogits.scalar_type());
  return (torch::nn::functional::softplus(other - own) * mask).sum() /
         mask.sum().clamp_min(1.0);
}

}  // namespace vln::models
