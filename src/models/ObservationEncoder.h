#pragma once
// The frozen (by default) visual encoders, separate from the policies: they
// run once per observation and their outputs ("features") can be cached on
// disk; policies consume feature maps. Images are Habitat's sensor layout
// (channels last); features are channels first.

#include <torch/torch.h>

#include <filesystem>

#include "models/ModelConfig.h"
#include "models/ResNet.h"

namespace vln::models {

/// RGB CNN: uint8 images [..., H, W, 3] -> float features [..., C, 4, 4]
/// (rgbFeatureShape()); with model.rgb_semantic_outputs N, the sigmoid of
/// the pretraining's semantic heads over that map, [..., N, 1, 1]. Pixels are
/// scaled to [0, 1] and, with model.normalize_rgb (the default), normalised
/// with the ImageNet mean/std inside (torchvision's weights expect it; VLN-CE's
/// encoder only divides by 255, which model.normalize_rgb: false reproduces).
/// ResNet outputs are adaptive-average-pooled to 4x4 as in VLN-CE.
class RgbEncoderImpl : public torch::nn::Module {
 public:
  explicit RgbEncoderImpl(const ModelConfig& config);
  torch::Tensor forward(const torch::Tensor& rgb);
  /// The module whose tensors a weight file holds (torchvision names for
  /// the ResNets).
  torch::nn::Module& cnnModule();
  /// With model.rgb_semantic_outputs: loads the CNN and the heads of an
  /// rgb_semantic pretraining's SemanticNet file (models/SemanticNet.h)
  /// strictly. Throws std::invalid_argument naming the file and the tensor
  /// or the sizes that do not fit.
  void loadSemanticNet(const std::filesystem::path& file);
  /// True when pixels are normalised with the ImageNet statistics
  /// (model.normalize_rgb), false when they are only divided by 255.
  bool normalizesWithImageNet() const { return normalize_; }

  TorchVisionResNet resnet{nullptr};  ///< set for resnet18/resnet50
  SmallCnn small{nullptr};            ///< set for small_cnn
  /// The pretraining's heads (categories, colours, room) as one layer; set
  /// with model.rgb_semantic_outputs.
  torch::nn::Linear semantic{nullptr};

 private:
  bool normalize_ = true;
};
TORCH_MODULE(RgbEncoder);

/// Depth CNN: float depth [..., H, W, 1] in [0, 1] -> features [..., C, h, w]
/// (depthFeatureShape()).
class DepthEncoderImpl : public torch::nn::Module {
 public:
  explicit DepthEncoderImpl(const ModelConfig& config);
  torch::Tensor forward(const torch::Tensor& depth);
  /// The module whose tensors a weight file holds (DD-PPO visual_encoder
  /// names for the ResNets).
  torch::nn::Module& cnnModule();

  DdppoResNetEncoder resnet{nullptr};  ///< set for resnet18/resnet50
  SmallCnn small{nullptr};             ///< set for small_cnn
};
TORCH_MODULE(DepthEncoder);

/// Feature maps of a batch of observations, channels first. A tensor is
/// undefined when the model does not use that modality.
struct VisualFeatures {
  torch::Tensor rgb;    ///< [..., C_rgb, h, w] float32
  torch::Tensor depth;  ///< [..., C_depth, h', w'] float32
};

/// Both visual encoders of a model. Ablated modalities (model.no_rgb,
/// model.no_depth) have no encoder. Frozen encoders (the default) have
/// requires_grad off and stay in eval mode even when train() is called, so
/// BatchNorm keeps its ImageNet statistics.
class ObservationEncoderImpl : public torch::nn::Module {
 public:
  explicit ObservationEncoderImpl(const ModelConfig& config);

  /// rgb uint8 [..., H, W, 3], depth float [..., H, W, 1] (same leading
  /// dims; either may be undefined when that modality is unused) -> feature
  /// maps with the same leading dims.
  VisualFeatures forward(const torch::Tensor& rgb, const torch::Tensor& depth);

  /// Loads model.rgb_weights / model.depth_weights (when set) strictly into
  /// the CNNs. Throws naming the file and every mismatched tensor.
  void loadPretrained();

  /// Keeps frozen encoders in eval mode.
  void train(bool on = true) override;

  /// With `on`, the RGB CNN's BatchNorm layers normalise by the statistics
  /// of each batch they see, without updating their running statistics
  /// (model.rgb_batch_statistics during collection); off restores the
  /// running statistics. Gradients are unaffected.
  void useRgbBatchStatistics(bool on);

  const ModelConfig& config() const { return config_; }

  RgbEncoder rgb{nullptr};      ///< undefined when model.no_rgb
  DepthEncoder depth{nullptr};  ///< undefined when model.no_depth

 private:
  ModelConfig config_;
};
TORCH_MODULE(ObservationEncoder);

}  // namespace vln::models
