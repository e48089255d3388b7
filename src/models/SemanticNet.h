#pragma once
// The network that pretrains the RGB encoder (train/SemanticPretrainer.h),
// the stand-in for the ImageNet classifier whose ResNet VLN-CE freezes:
// the RGB CNN (model.rgb_encoder) and one linear head per output over its
// flattened feature maps: multi-label object categories, multi-label
// colours, and the room type.

#include <torch/torch.h>

#include <cstdint>

#include "models/ModelConfig.h"
#include "models/ObservationEncoder.h"

namespace vln::models {

/// Logits of SemanticNet for a batch of N images.
struct SemanticLogits {
  torch::Tensor categories;  ///< [N, categories] float
  torch::Tensor colors;      ///< [N, colours] float
  torch::Tensor room;        ///< [N, room types] float
};

class SemanticNetImpl : public torch::nn::Module {
 public:
  /// Heads of `categories`, `colors` and `rooms` outputs (the sizes of the
  /// world's vocabularies).
  SemanticNetImpl(const ModelConfig& model, int64_t categories, int64_t colors,
                  int64_t rooms);
  /// rgb uint8 [N, H, W, 3] -> logits.
  SemanticLogits forward(const torch::Tensor& rgb);

  RgbEncoder rgb{nullptr};
  torch::nn::Linear categories{nullptr};
  torch::nn::Linear colors{nullptr};
  torch::nn::Linear room{nullptr};
};
TORCH_MODULE(SemanticNet);

}  // namespace vln::models
