#pragma once
// The sequence-to-sequence baseline (paper Section 4.1, VLN-CE Seq2SeqNet):
//   v_t = ReLU(W_v mean-pool(V_t) + b),  d_t = ReLU(W_d flatten(D_t) + b),
//   s   = final LSTM state of the instruction,
//   h_t = GRU([s, d_t, v_t (, a_{t-1})], h_{t-1}),  logits = W_a h_t + b_a.
// Sizes with the defaults: RGB 2048 -> 256, depth 128x4x4 -> 128,
// instruction 128, GRU 512, 4 actions. The mean-pool runs over the cached
// 4x4 RGB map (VLN-CE pools the full ResNet map; identical when the map
// divides evenly).

#include <torch/torch.h>

#include "models/MaskedGru.h"
#include "models/Policy.h"

namespace vln::models {

class Seq2SeqPolicyImpl : public PolicyImpl {
 public:
  /// config.policy must be seq2seq.
  explicit Seq2SeqPolicyImpl(const ModelConfig& config);

  PolicyOutputs forwardSequence(const EncodedInstruction& instruction,
                                const PolicyInputs& inputs,
                                const torch::Tensor& hidden) override;

  torch::nn::Linear rgb_linear{nullptr};    ///< [rgb_projection, C_rgb]
  torch::nn::Linear depth_linear{nullptr};  ///< [depth_projection, C*h*w]
  torch::nn::Embedding prev_action_embedding{nullptr};  ///< [5, 32]
  MaskedGru state_encoder{nullptr};
  torch::nn::Linear action_head{nullptr};       ///< [4, hidden]
  torch::nn::Linear progress_monitor{nullptr};  ///< [1, hidden]

 protected:
  EncodedInstruction prepareInstruction(
      const InstructionStates& states) override;
};
TORCH_MODULE(Seq2SeqPolicy);

}  // namespace vln::models
