#pragma once
// Instruction encoder (paper Section 4, "Instruction Representation"): GloVe
// word embeddings then an LSTM. Seq2Seq keeps the final hidden state, CMA a
// bidirectional LSTM's states at every token. Instructions are token ids
// [B, L] padded at the end with PAD = 0; sequences are packed by length, so
// padding never changes any output.
//
// With model.instruction_features: rxr_text (RxR_VLNCE, as VLN-CE's
// InstructionEncoder with sensor_uuid rxr_instruction) the input is instead
// precomputed per-token features float [B, L, text_feature_dim], padded at
// the end with all-zero rows (RxR pads to 512), and they enter the same
// (Bi)LSTM directly: there is no embedding layer.

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

/// Embedding + (Bi)LSTM over token ids, or (Bi)LSTM over text features.
class InstructionEncoderImpl : public torch::nn::Module {
 public:
  /// Sizes come from `config` (vocab_size, embedding_dim or
  /// text_feature_dim, instruction_hidden_size); bidirectional for CMA. The
  /// embedding (tokens only) is frozen unless config.fine_tune_embeddings.
  explicit InstructionEncoderImpl(const ModelConfig& config);

  /// Tokens: int64 [B, L], each row real tokens then PAD (0), at least one
  /// real token; throws std::invalid_argument for ids outside
  /// [0, vocab_size), an empty row or a PAD before a real token.
  /// Text features: float [B, L, text_feature_dim]; a row's length is the
  /// index of its last non-zero feature row + 1 (zero rows after it are
  /// padding and never change any output; VLN-CE counts the non-zero rows,
  /// the same for RxR's files); throws std::invalid_argument for another
  /// shape or dtype, or a row that is all zeros.
  InstructionStates forward(const torch::Tensor& instruction);

  /// Copies a [vocab_size, embedding_dim] matrix (GloVe, PAD row zero) into
  /// the embedding. Throws std::invalid_argument on a shape mismatch, or
  /// with text features (no embedding).
  void setWordEmbeddings(const torch::Tensor& matrix);

  /// Lengths (non-PAD tokens) of each row, int64 [B] on the CPU, after the
  /// checks of forward().
  torch::Tensor lengths(const torch::Tensor& tokens) const;

  /// Lengths (last non-zero row + 1) of text features [B, L, D], int64 [B]
  /// on the CPU, after the checks of forward().
  torch::Tensor featureLengths(const torch::Tensor& features) const;

  /// Undefined with text features.
  torch::nn::Embedding embedding{nullptr};
  torch::nn::LSTM lstm{nullptr};

 private:
  // (Bi)LSTM over embedded rows [B, L, E] packed by `lens` (CPU int64 [B])
  InstructionStates encode(const torch::Tensor& embedded,
                           const torch::Tensor& lens);

  int64_t vocabSize_;
  int64_t featureDim_;
  bool textFeatures_;
  bool bidirectional_;
};
TORCH_MODULE(InstructionEncoder);

/// A random [vocab, dim] word-embedding matrix for setWordEmbeddings():
/// rows N(0, 1) (nn.Embedding's own initialisation) from a generator seeded
/// with `seed` alone, so the draw leaves the global torch RNG untouched; PAD
/// (row 0) zero. The same seed gives the same matrix.
torch::Tensor randomWordEmbeddings(int64_t vocab, int64_t dim, uint64_t seed);

}  // namespace vln::models
