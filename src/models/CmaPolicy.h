#pragma once
// The cross-modal attention agent (paper Section 4.2, VLN-CE CMANet):
//   h^attn_t = GRU1([v_t, d_t, a_{t-1}])            (v_t, d_t as Seq2Seq, but
//              over features with a learned 64-d per-position embedding)
//   s^_t = Attn(S, state_q(h^attn_t))                (S: BiLSTM states, keys
//                                                     text_k(S), PAD masked)
//   v^_t = Attn(V_t, text_q(s^_t)),  d^_t = Attn(D_t, text_q(s^_t))
//              (keys and values from a linear map of [feature, position])
//   h^a_t = GRU2(ReLU(W [h^attn_t, s^_t, v^_t, d^_t, a_{t-1}]))
//   logits = W_a h^a_t + b_a
// With model.turn_count_embedding_dim, an embedding of the turn count c_t
// (turnCounts()) joins a_{t-1} in both GRUs' inputs.
// Attn(X, q) = sum_i softmax_i((W_k x_i + b_k) . q / sqrt(hidden/2)) (W_v x_i
// + b_v). Defaults: GRUs 512, keys 256, RGB value 256, depth value 128,
// previous action 32.
//
// The visual attention is evaluated without projecting every location:
// because the scores and the weighted sum are linear in x_i, it computes
// q' = W_k^T q, scores x_i . q', the attended raw feature sum_i a_i x_i and
// only then W_v of it. This is the same function as VLN-CE's (checked by a
// test against the direct form) at about 1/30 of the cost for 2048-channel
// ResNet features, and frozen features need no input gradient.

#include <torch/torch.h>

#include "models/MaskedGru.h"
#include "models/Policy.h"

namespace vln::models {

class CmaPolicyImpl : public PolicyImpl {
 public:
  /// config.policy must be cma.
  explicit CmaPolicyImpl(const ModelConfig& config);

  PolicyOutputs forwardSequence(const EncodedInstruction& instruction,
                                const PolicyInputs& inputs,
                                const torch::Tensor& hidden) override;

  /// Learned per-position embeddings, [h*w, spatial_embedding_dim]; read as
  /// a [spatial_embedding_dim, h*w] map (VLN-CE's view).
  torch::nn::Embedding rgb_spatial_embedding{nullptr};
  torch::nn::Embedding depth_spatial_embedding{nullptr};
  /// Projections of mean-pooled RGB [C+64] and flattened depth [(C+64)*h*w].
  torch::nn::Linear rgb_linear{nullptr};
  torch::nn::Linear depth_linear{nullptr};
  torch::nn::Embedding prev_action_embedding{nullptr};  ///< [5, 32]
  /// With model.turn_count_embedding_dim: [2 * kMaxTurnCount + 1, dim].
  torch::nn::Embedding turn_count_embedding{nullptr};
  MaskedGru state_encoder{nullptr};                     ///< GRU1
  torch::nn::Linear state_q{nullptr};  ///< GRU1 state -> text query
  torch::nn::Linear text_k{nullptr};   ///< instruction state -> key
  torch::nn::Linear text_q{nullptr};   ///< attended text -> visual query
  /// Visual keys and values: rows [0, hidden/2) keys, then values.
  torch::nn::Linear rgb_kv{nullptr};
  torch::nn::Linear depth_kv{nullptr};
  /// With model.no_instruction: the constant visual query, [hidden/2].
  torch::Tensor visual_query;
  torch::nn::Linear second_state_compress{nullptr};
  MaskedGru second_state_encoder{nullptr};  ///< GRU2
  torch::nn::Linear action_head{nullptr};
  torch::nn::Linear progress_monitor{nullptr};

 protected:
  EncodedInstruction prepareInstruction(
      const InstructionStates& states) override;

 private:
  /// Attention of queries q [N, hidden/2] over feature maps feats [N, C, P]
  /// with positions pos [E, P] and key/value layer kv -> [N, value size].
  torch::Tensor attendVisual(const torch::Tensor& q, const torch::Tensor& feats,
                             const torch::Tensor& pos,
                             torch::nn::Linear& kv) const;
  double scale_;
};
TORCH_MODULE(CmaPolicy);

/// The net turns since the last MOVE_FORWARD at each step, float [T, B]:
/// c_t = 0 on an episode's first step (not_done 0), after MOVE_FORWARD 0,
/// after TURN_LEFT c_{t-1} + 1, after TURN_RIGHT c_{t-1} - 1, after any
/// other action c_{t-1}; clamped to [-kMaxTurnCount, kMaxTurnCount].
/// prevActions and notDone [T, B]; start [B], the count before step 0.
torch::Tensor turnCounts(const torch::Tensor& prevActions,
                         const torch::Tensor& notDone,
                         const torch::Tensor& start);

}  // namespace vln::models
