#pragma once
// A single-layer GRU over time-major sequences whose hidden state is reset
// at episode starts (habitat_baselines' RNNStateEncoder semantics): before
// step t the state is multiplied by not_done[t], which is 0 on the first
// step of an episode. The sequence is cut at the steps where some row
// resets, and each chunk runs as one fused GRU call (LibTorch precomputes the
// input projection of a whole chunk on the CPU), so teacher forcing with
// resets only at t = 0 is a single call.

#include <torch/torch.h>

#include <utility>

namespace vln::models {

class MaskedGruImpl : public torch::nn::Module {
 public:
  /// Weights orthogonal, biases zero (habitat's RNNStateEncoder init).
  MaskedGruImpl(int64_t inputSize, int64_t hiddenSize);

  /// x [T, B, inputSize], h0 [B, hiddenSize], notDone [T, B] (float 0/1) ->
  /// (outputs [T, B, hiddenSize], final state [B, hiddenSize]).
  std::pair<torch::Tensor, torch::Tensor> forward(const torch::Tensor& x,
                                                  const torch::Tensor& h0,
                                                  const torch::Tensor& notDone);

  torch::nn::GRU gru{nullptr};
};
TORCH_MODULE(MaskedGru);

}  // namespace vln::models
