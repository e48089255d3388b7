#pragma once
// A small contextual text encoder whose per-token outputs stand in for the
// BERT features RxR ships (text_features/rxr_{split}/..., [tokens, 768]),
// trained as a masked language model (train/TextPretrainer.h).
//
// Why a transformer and not a BiLSTM: RxR's features are the last layer of
// a transformer, where every row is a function of the whole instruction
// through attention; a transformer layer computes all positions of an
// instruction in one matrix product, which on a CPU is faster than the 2 x L
// sequential steps of a BiLSTM for RxR's long instructions (100-200 words);
// and padding is a key mask that gives padded keys exactly zero weight, so an
// instruction's features do not depend on what it is batched with (up to
// float rounding of the batch shape; the feature writer encodes one
// instruction at a time).
//
// Layout: token embedding + learned position embedding (hidden_size), then
// `layers` pre-norm transformer layers (LayerNorm -> self-attention ->
// residual, LayerNorm -> ReLU feed-forward -> residual), a final LayerNorm,
// then the feature head Linear(hidden_size, output_dim) + LayerNorm: the
// features, [B, L, output_dim]. The masked-LM head reads the features
// (Linear(output_dim, vocab)), so the written columns are exactly what the
// model predicts words from.
//
// Tokens are vocabulary ids [B, L] int64: real tokens, then PAD (0) at the
// end of each row. Feature rows at PAD are zero (RxR's zero padding rows).

#include <torch/torch.h>

#include <cstdint>
#include <random>
#include <vector>

#include "models/TextEncoderConfig.h"

namespace vln::models {

/// Label of a position the masked-LM loss ignores (torch's ignore_index).
inline constexpr int64_t kMlmIgnore = -100;

/// One pre-norm transformer encoder layer over [L, B, hidden] inputs.
class TextEncoderLayerImpl : public torch::nn::Module {
 public:
  explicit TextEncoderLayerImpl(const TextEncoderConfig& config);
  /// x float [L, B, hidden]; padding bool [B, L], true at PAD keys.
  /// Returns [L, B, hidden].
  torch::Tensor forward(const torch::Tensor& x, const torch::Tensor& padding);

  torch::nn::LayerNorm norm1{nullptr}, norm2{nullptr};
  torch::nn::MultiheadAttention attention{nullptr};
  torch::nn::Linear ff1{nullptr}, ff2{nullptr};
  torch::nn::Dropout dropout{nullptr};
};
TORCH_MODULE(TextEncoderLayer);

/// The text encoder with its masked-LM head (see the file comment).
class TextFeatureEncoderImpl : public torch::nn::Module {
 public:
  /// `vocab_size` ids (PAD = 0); sizes from `config` (validated).
  TextFeatureEncoderImpl(const TextEncoderConfig& config, int64_t vocab_size);

  /// tokens int64 [B, L], L <= max_tokens, each row real tokens then PAD
  /// (0). Returns the features, float32 [B, L, output_dim], zero rows at
  /// PAD. TORCH_CHECKs ids outside [0, vocab_size) and L > max_tokens.
  torch::Tensor forward(const torch::Tensor& tokens);

  /// Word logits of features [B, L, output_dim]: [B, L, vocab_size].
  torch::Tensor mlmLogits(const torch::Tensor& features);

  /// The features of one instruction, ids without padding (1 <= n <=
  /// max_tokens): [n, output_dim] float32 on the CPU, computed alone and in
  /// eval mode (no dropout), so it depends only on the ids and the weights.
  torch::Tensor encodeOne(const std::vector<int>& ids);

  int64_t vocabSize() const { return vocabSize_; }
  const TextEncoderConfig& config() const { return config_; }

  torch::nn::Embedding tokenEmbedding{nullptr};
  torch::nn::Embedding positionEmbedding{nullptr};
  torch::nn::ModuleList layers{nullptr};
  torch::nn::LayerNorm finalNorm{nullptr};
  torch::nn::Linear featureHead{nullptr};
  torch::nn::LayerNorm featureNorm{nullptr};
  torch::nn::Linear mlmHead{nullptr};

 private:
  TextEncoderConfig config_;
  int64_t vocabSize_;
};
TORCH_MODULE(TextFeatureEncoder);

/// How maskTokens() corrupts a batch (BERT's scheme by default).
struct MlmMaskOptions {
  int64_t mask_index = 0;  ///< id of the "<mask>" token
  /// Random replacements are drawn uniformly from [random_low, random_high).
  int64_t random_low = 2;
  int64_t random_high = 2;
  double probability = 0.15;    ///< chance that a real token is predicted
  double replace_mask = 0.8;    ///< of those: replaced by <mask>
  double replace_random = 0.1;  ///< of those: replaced by a random word
};

/// The input and labels of one masked-LM batch.
struct MlmBatch {
  torch::Tensor inputs;  ///< int64 [B, L], corrupted tokens
  torch::Tensor labels;  ///< int64 [B, L], the original id where predicted,
                         ///< kMlmIgnore elsewhere (and at PAD)
};

/// Chooses each non-PAD position of `tokens` (int64 [B, L] on the CPU) with
/// options.probability and replaces it by <mask>, a random word or itself
/// (replace_mask / replace_random / the rest); draws only from `rng`
/// (common/Random.h helpers, row-major order), so the result is a function
/// of the seed.
MlmBatch maskTokens(const torch::Tensor& tokens, const MlmMaskOptions& options,
                    std::mt19937_64& rng);

/// `sentences` (ids, no padding) as int64 [B, Lmax] right-padded with 0.
torch::Tensor padTokenRows(const std::vector<std::vector<int>>& sentences);

}  // namespace vln::models
