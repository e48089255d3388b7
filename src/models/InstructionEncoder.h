#pragma once
// Instruction encoder (paper Section 4, "Instruction Representation"): GloVe
// word embeddings then an LSTM. Seq2Seq keeps the final hidden state, CMA a
// bidirectional LSTM's states at every token. Instructions are token ids
// [B, L] padded at the end with PAD = 0; sequences are packed by length, so
// padding never changes any output.

#include <torch/torch.h>

#include "models/ModelConfig.h"

namespace vln::models {

/// Output of the instruction encoder for a batch.
struct InstructionStates {
  torch::Tensor states;  ///< [B, Lmax, D] float, zeros past each length;
                         ///< D = hidden (x2 bidirectional), Lmax = longest
  torch::Tensor mask;    ///< [B, Lmax] bool, true at real tokens
  torch::Tensor last;    ///< [B, hidden] final state of the forward direction
};

/// Embedding + (Bi)LSTM over token ids.
class InstructionEncoderImpl : public torch::nn::Module {
 public:
  /// Sizes come from `config` (vocab_size, embedding_dim,
  /// instruction_hidden_size); bidirectional for CMA. The embedding is
  /// frozen unless config.fine_tune_embeddings.
  explicit InstructionEncoderImpl(const ModelConfig& config);

  /// tokens int64 [B, L], each row real tokens then PAD (0), at least one
  /// real token. Throws std::invalid_argument for ids outside
  /// [0, vocab_size), an empty row or a PAD before a real token.
  InstructionStates forward(const torch::Tensor& tokens);

  /// Copies a [vocab_size, embedding_dim] matrix (GloVe, PAD row zero) into
  /// the embedding. Throws std::invalid_argument on a shape mismatch.
  void setWordEmbeddings(const torch::Tensor& matrix);

  /// Lengths (non-PAD tokens) of each row, int64 [B] on the CPU, after the
  /// checks of forward().
  torch::Tensor lengths(const torch::Tensor& tokens) const;

  torch::nn::Embedding embedding{nullptr};
  torch::nn::LSTM lstm{nullptr};

 private:
  int64_t vocabSize_;
  bool bidirectional_;
};
TORCH_MODULE(InstructionEncoder);

}  // namespace vln::models
