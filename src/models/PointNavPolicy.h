#pragma once
// The point-goal navigation policy that pretrains the depth encoder
// (train/PointNavPretrainer.h), the stand-in for DD-PPO's point-goal agent
// whose ResNet VLN-CE freezes: depth CNN (model.depth_encoder) -> linear +
// ReLU projection (model.depth_projection_size), a linear goal embedding
// and a previous-action embedding (32 wide each, as DD-PPO), a GRU and an
// action head. Without depth it is the blind control the pretrainer trains
// beside it.

#include <torch/torch.h>

#include <cstdint>
#include <utility>

#include "models/MaskedGru.h"
#include "models/ModelConfig.h"
#include "models/ObservationEncoder.h"

namespace vln::models {

/// Width of the goal observation.
inline constexpr int64_t kPointGoalDims = 3;

/// Inputs of PointNavPolicy, time-major over T steps of B episodes; only
/// the N real (unpadded) steps carry a depth frame.
struct PointNavInputs {
  torch::Tensor depth;         ///< [N, H, W, 1] float in the sensor's range;
                               ///< undefined for a blind policy
  torch::Tensor frame_index;   ///< [N] int64: t * B + b of each frame
  torch::Tensor goal;          ///< [T, B, 3] float, pointGoalObservation()
  torch::Tensor prev_actions;  ///< [T, B] int64, the action before this step
                               ///< (any value where not_done = 0)
  torch::Tensor not_done;      ///< [T, B] float 0/1, 0 at an episode's start
};

/// The point-goal policy (see the file comment).
class PointNavPolicyImpl : public torch::nn::Module {
 public:
  /// The depth CNN is model.depth_encoder at model.depth_width x
  /// depth_height; `useDepth` = false builds the blind control.
  PointNavPolicyImpl(const ModelConfig& model, int64_t hiddenSize,
                     bool useDepth);

  /// inputs over [T, B], hidden [B, hidden_size] before step 0 (reset
  /// where not_done is 0) -> (logits [T, B, 4], hidden after step T-1).
  std::pair<torch::Tensor, torch::Tensor> forward(const PointNavInputs& inputs,
                                                  const torch::Tensor& hidden);

  /// Zeros [batch, hidden_size].
  torch::Tensor initialHidden(int64_t batch) const;
  bool usesDepth() const { return !depth.is_empty(); }

  DepthEncoder depth{nullptr};  ///< undefined for the blind control
  torch::nn::Linear depth_fc{nullptr};
  torch::nn::Linear goal_embedding{nullptr};
  torch::nn::Embedding prev_action_embedding{nullptr};
  MaskedGru gru{nullptr};
  torch::nn::Linear action{nullptr};

 private:
  int64_t hiddenSize_;
};
TORCH_MODULE(PointNavPolicy);

}  // namespace vln::models
