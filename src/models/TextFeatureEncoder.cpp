#include "models/TextFeatureEncoder.h"

#include <algorithm>

#include "common/Random.h"

namespace vln::models {

// ===========================================================================
// TextEncoderLayer
// ===========================================================================

TextEncoderLayerImpl::TextEncoderLayerImpl(const TextEncoderConfig& config) {
  const int64_t hidden = config.hidden_size;
  norm1 = register_module(
      "norm1", torch::nn::LayerNorm(torch::nn::LayerNormOptions({hidden})));
  norm2 = register_module(
      "norm2", torch::nn::LayerNorm(torch::nn::LayerNormOptions({hidden})));
  attention = register_module(
      "attention",
      torch::nn::MultiheadAttention(
          torch::nn::MultiheadAttentionOptions(hidden, config.heads)
              .dropout(config.dropout)));
  ff1 = register_module("ff1", torch::nn::Linear(hidden, config.ff_size));
  ff2 = register_module("ff2", torch::nn::Linear(config.ff_size, hidden));
  dropout = register_module("dropout", torch::nn::Dropout(config.dropout));
}

torch::Tensor TextEncoderLayerImpl::forward(const torch::Tensor& x,
                                            const torch::Tensor& padding) {
  // self-attention over the real tokens (PAD keys get zero weight)
  const torch::Tensor h = norm1(x);
  torch::Tensor attended =
      std::get<0>(attention(h, h, h, padding, /*need_weights=*/false));
  torch::Tensor y = x + dropout(attended);
  // position-wise feed-forward
  return y + dropout(ff2(torch::relu(ff1(norm2(y)))));
}

// ===========================================================================
// TextFeatureEncoder
// ===========================================================================

TextFeatureEncoderImpl::TextFeatureEncoderImpl(const TextEncoderConfig& config,
                                               int64_t vocab_size)
    : config_(config), vocabSize_(vocab_size) {
  config.validate();
  TORCH_CHECK(vocab_size > 2,
              "TextFeatureEncoder(): a vocabulary needs more than <pad> and "
              "<unk>, got ",
              vocab_size, " words");
  const int64_t hidden = config.hidden_size;
  tokenEmbedding = register_module(
      "token_embedding",
      torch::nn::Embedding(
          torch::nn::EmbeddingOptions(vocab_size, hidden).padding_idx(0)));
  positionEmbedding = register_module(
      "position_embedding", torch::nn::Embedding(config.max_tokens, hidden));
  layers = register_module("layers", torch::nn::ModuleList());
  for (int i = 0; i < config.layers; ++i)
    layers->push_back(TextEncoderLayer(config));
  finalNorm = register_module(
      "final_norm",
      torch::nn::LayerNorm(torch::nn::LayerNormOptions({hidden})));
  featureHead = register_module("feature_head",
                                torch::nn::Linear(hidden, config.output_dim));
  featureNorm = register_module(
      "feature_norm", torch::nn::LayerNorm(torch::nn::LayerNormOptions(
                          {static_cast<int64_t>(config.output_dim)})));
  mlmHead = register_module("mlm_head",
                            torch::nn::Linear(config.output_dim, vocab_size));

  // BERT's initialisation of the embeddings: N(0, 0.02), PAD row zero
  torch::NoGradGuard noGrad;
  tokenEmbedding->weight.normal_(0.0, 0.02);
  tokenEmbedding->weight[0].zero_();
  positionEmbedding->weight.normal_(0.0, 0.02);
}

torch::Tensor TextFeatureEncoderImpl::forward(const torch::Tensor& tokens) {
  TORCH_CHECK(tokens.dim() == 2 && tokens.scalar_type() == torch::kInt64,
              "TextFeatureEncoder::forward(): expected int64 [B, L], got ",
              tokens.scalar_type(), " ", tokens.sizes());
  const int64_t length = tokens.size(1);
  TORCH_CHECK(length >= 1 && length <= config_.max_tokens,
              "TextFeatureEncoder::forward(): L must be in [1, max_tokens = ",
              config_.max_tokens, "], got ", length);
  TORCH_CHECK(
      tokens.numel() == 0 || (tokens.min().item<int64_t>() >= 0 &&
                              tokens.max().item<int64_t>() < vocabSize_),
      "TextFeatureEncoder::forward(): token ids must be in [0, ", vocabSize_,
      ")");
  // embeddings of the tokens and their positions, as [L, B, hidden]
  const torch::Tensor positions =
      torch::arange(length, tokens.options()).unsqueeze(0);
  torch::Tensor x = tokenEmbedding(tokens) + positionEmbedding(positions);
  x = x.transpose(0, 1);
  const torch::Tensor padding = tokens.eq(0);
  for (const auto& layer : *layers)
    x = layer->as<TextEncoderLayer>()->forward(x, padding);
  // the feature head, PAD rows zeroed
  torch::Tensor features =
      featureNorm(featureHead(finalNorm(x.transpose(0, 1))));
  return features.masked_fill(padding.unsqueeze(-1), 0.0);
}

torch::Tensor TextFeatureEncoderImpl::mlmLogits(const torch::Tensor& features) {
  TORCH_CHECK(features.dim() == 3 && features.size(2) == config_.output_dim,
              "TextFeatureEncoder::mlmLogits(): expected [B, L, ",
              config_.output_dim, "], got ", features.sizes());
  return mlmHead(features);
}

torch::Tensor TextFeatureEncoderImpl::encodeOne(const std::vector<int>& ids) {
  TORCH_CHECK(
      !ids.empty() && static_cast<int64_t>(ids.size()) <= config_.max_tokens,
      "TextFeatureEncoder::encodeOne(): expected 1 to ", config_.max_tokens,
      " tokens, got ", ids.size());
  TORCH_CHECK(std::find(ids.begin(), ids.end(), 0) == ids.end(),
              "TextFeatureEncoder::encodeOne(): PAD (0) inside the ids");
  const bool wasTraining = is_training();
  eval();
  torch::NoGradGuard noGrad;
  const torch::Device device = tokenEmbedding->weight.device();
  torch::Tensor features =
      forward(padTokenRows({ids}).to(device)).squeeze(0).to(torch::kCPU);
  train(wasTraining);
  return features.contiguous();
}

// ===========================================================================
// masking
// ===========================================================================

MlmBatch maskTokens(const torch::Tensor& tokens, const MlmMaskOptions& options,
                    std::mt19937_64& rng) {
  TORCH_CHECK(tokens.dim() == 2 && tokens.scalar_type() == torch::kInt64 &&
                  tokens.device().is_cpu(),
              "maskTokens(): expected int64 [B, L] on the CPU, got ",
              tokens.scalar_type(), " ", tokens.sizes());
  TORCH_CHECK(
      options.random_high > options.random_low || options.replace_random == 0.0,
      "maskTokens(): empty random word range [", options.random_low, ", ",
      options.random_high, ")");
  MlmBatch batch;
  batch.inputs = tokens.clone().contiguous();
  batch.labels = torch::full_like(tokens, kMlmIgnore).contiguous();
  int64_t* in = batch.inputs.data_ptr<int64_t>();
  int64_t* label = batch.labels.data_ptr<int64_t>();
  const int range = static_cast<int>(options.random_high - options.random_low);
  // row-major: one decision per real token, then what replaces it
  for (int64_t i = 0; i < batch.inputs.numel(); ++i) {
    if (in[i] == 0 || !common::bernoulli(rng, options.probability)) continue;
    label[i] = in[i];
    const double u = common::uniform01(rng);
    if (u < options.replace_mask) {
      in[i] = options.mask_index;
    } else if (u < options.replace_mask + options.replace_random) {
      in[i] = options.random_low + common::uniformIndex(rng, range);
    }
  }
  return batch;
}

torch::Tensor padTokenRows(const std::vector<std::vector<int>>& sentences) {
  size_t longest = 0;
  for (const auto& s : sentences) longest = std::max(longest, s.size());
  torch::Tensor out = torch::zeros(
      {static_cast<int64_t>(sentences.size()), static_cast<int64_t>(longest)},
      torch::kInt64);
  auto rows = out.accessor<int64_t, 2>();
  for (size_t b = 0; b < sentences.size(); ++b)
    for (size_t t = 0; t < sentences[b].size(); ++t)
      rows[static_cast<int64_t>(b)][static_cast<int64_t>(t)] = sentences[b][t];
  return out;
}

}  // namespace vln::models
