#pragma once
// Tiny model configurations and random inputs shared by the model tests.
// Sizes are deliberately small and pairwise distinct, so that a wrong
// dimension cannot go unnoticed by accident.

#include <torch/torch.h>

#include <vector>

#include "models/ModelConfig.h"
#include "models/Policy.h"

namespace vln::models::test {

/// A tiny model on 32x32 images with small CNNs.
inline ModelConfig tinyConfig(PolicyType policy) {
  ModelConfig c;
  c.policy = policy;
  c.rgb_encoder = EncoderType::kSmallCnn;
  c.depth_encoder = EncoderType::kSmallCnn;
  c.vocab_size = 23;
  c.embedding_dim = 6;
  c.instruction_hidden_size = 5;
  c.hidden_size = 10;
  c.prev_action_embedding_dim = 3;
  c.rgb_projection_size = 7;
  c.depth_projection_size = 9;
  c.spatial_embedding_dim = 4;
  c.progress_monitor = true;
  c.rgb_height = c.rgb_width = 32;
  c.depth_height = c.depth_width = 32;
  return c;
}

/// Random token rows with the given lengths, PAD (0) after each, [B, width].
inline torch::Tensor randomTokens(const std::vector<int64_t>& lengths,
                                  int64_t width, int64_t vocab) {
  torch::Tensor tokens = torch::zeros(
      {static_cast<int64_t>(lengths.size()), width}, torch::kInt64);
  for (size_t b = 0; b < lengths.size(); ++b)
    tokens[static_cast<int64_t>(b)]
        .slice(0, 0, lengths[b])
        .copy_(torch::randint(1, vocab, {lengths[b]}, torch::kInt64));
  return tokens;
}

/// `config` reading RxR-style text features ([B, L, 8]) instead of tokens,
/// with RxR's six actions.
inline ModelConfig tinyRxrConfig(PolicyType policy) {
  ModelConfig c = tinyConfig(policy);
  c.instruction_features = InstructionFeatures::kRxrText;
  c.text_feature_dim = 8;
  c.num_actions = static_cast<int>(kNumLookActions);
  c.seq2seq_prev_action = true;
  return c;
}

/// Random text features with the given lengths, zero rows after each,
/// [B, width, dim] float.
inline torch::Tensor randomTextFeatures(const std::vector<int64_t>& lengths,
                                        int64_t width, int64_t dim) {
  torch::Tensor features = torch::zeros(
      {static_cast<int64_t>(lengths.size()), width, dim}, torch::kFloat32);
  for (size_t b = 0; b < lengths.size(); ++b)
    features[static_cast<int64_t>(b)]
        .slice(0, 0, lengths[b])
        .copy_(torch::randn({lengths[b], dim}));
  return features;
}

/// Random sequence-mode inputs [T, B, ...] for `config`, with episode
/// starts at t = 0 and wherever `resets` (pairs t, b) say.
inline PolicyInputs randomInputs(
    const ModelConfig& config, int64_t steps, int64_t batch,
    const std::vector<std::pair<int64_t, int64_t>>& resets = {},
    torch::Dtype dtype = torch::kFloat32) {
  const FeatureShape r = rgbFeatureShape(config);
  const FeatureShape d = depthFeatureShape(config);
  PolicyInputs in;
  in.rgb = torch::rand({steps, batch, r[0], r[1], r[2]}, dtype);
  in.depth = torch::rand({steps, batch, d[0], d[1], d[2]}, dtype);
  in.prev_actions =
      torch::randint(0, config.num_actions, {steps, batch}, torch::kInt64);
  in.not_done = torch::ones({steps, batch}, dtype);
  in.not_done[0].zero_();
  for (const auto& [t, b] : resets) in.not_done[t][b] = 0;
  return in;
}

/// Step t of sequence-mode inputs.
inline PolicyInputs stepOf(const PolicyInputs& in, int64_t t) {
  return {in.rgb[t], in.depth[t], in.prev_actions[t], in.not_done[t]};
}

}  // namespace vln::models::test
