#pragma once
// The convolutional backbones behind the visual encoders. Submodule and
// parameter names reproduce the reference implementations exactly, so that
// converted pretrained weights load by name:
//  - TorchVisionResNet: torchvision.models.resnet18/resnet50 (BatchNorm),
//    names "conv1.weight", "bn1.running_mean", "layer1.0.conv1.weight",
//    "layer2.0.downsample.0.weight", ... (the classifier "fc" is omitted);
//  - DdppoResNetEncoder: habitat_baselines' DD-PPO ResNetEncoder (GroupNorm)
//    with its compression conv, names "backbone.conv1.0.weight",
//    "backbone.layer1.0.convs.0.weight", "compression.0.weight", ...
//    (the checkpoint's actor_critic.net.visual_encoder.* with that prefix
//    removed);
//  - SmallCnn: a few 3x3 convs (three strided ones by default) for fast CPU
//    runs.
// All take float images [N, C, H, W] and return feature maps [N, C', h, w].

#include <torch/torch.h>

#include <cstdint>
#include <vector>

namespace vln::models {

// ---------------------------------------------------------------------------
// torchvision ResNet (ImageNet weights)
// ---------------------------------------------------------------------------

/// One torchvision residual block: BasicBlock (conv1/bn1/conv2/bn2) or
/// Bottleneck (conv1..3/bn1..3, expansion 4), with an optional downsample
/// (1x1 conv + BatchNorm) on the shortcut.
class TvBlockImpl : public torch::nn::Module {
 public:
  TvBlockImpl(int64_t inplanes, int64_t planes, int64_t stride,
              bool bottleneck);
  /// [N, inplanes, H, W] -> [N, planes * expansion, H / stride, W / stride].
  torch::Tensor forward(const torch::Tensor& x);

  bool bottleneck;
  torch::nn::Conv2d conv1{nullptr}, conv2{nullptr}, conv3{nullptr};
  torch::nn::BatchNorm2d bn1{nullptr}, bn2{nullptr}, bn3{nullptr};
  torch::nn::Sequential downsample{nullptr};
};
TORCH_MODULE(TvBlock);

/// torchvision ResNet-18/50 without avgpool and fc: [N, 3, H, W] normalised
/// RGB -> [N, 512 or 2048, ceil(H/32), ceil(W/32)].
class TorchVisionResNetImpl : public torch::nn::Module {
 public:
  /// `layers` is 18 or 50.
  explicit TorchVisionResNetImpl(int layers);
  torch::Tensor forward(const torch::Tensor& x);
  /// Channels of the output map (512 or 2048).
  int64_t outputChannels() const { return outputChannels_; }

  torch::nn::Conv2d conv1{nullptr};
  torch::nn::BatchNorm2d bn1{nullptr};
  torch::nn::Sequential layer1{nullptr}, layer2{nullptr}, layer3{nullptr},
      layer4{nullptr};

 private:
  int64_t outputChannels_ = 0;
};
TORCH_MODULE(TorchVisionResNet);

// ---------------------------------------------------------------------------
// DD-PPO ResNet (GroupNorm, depth)
// ---------------------------------------------------------------------------

/// One DD-PPO residual block: body `convs` (BasicBlock: conv3x3-GN-ReLU-
/// conv3x3-GN; Bottleneck: conv1x1-GN-ReLU-conv3x3(stride)-GN-ReLU-
/// conv1x1-GN, expansion 4) plus optional `downsample` (conv1x1 + GN).
class DdppoBlockImpl : public torch::nn::Module {
 public:
  DdppoBlockImpl(int64_t inplanes, int64_t planes, int64_t ngroups,
                 int64_t stride, bool bottleneck);
  torch::Tensor forward(const torch::Tensor& x);

  torch::nn::Sequential convs{nullptr};
  torch::nn::Sequential downsample{nullptr};
};
TORCH_MODULE(DdppoBlock);

/// DD-PPO's ResNet backbone: `conv1` (7x7/2 conv, GN, ReLU), 3x3/2 max pool,
/// layer1..4 with widths base, 2base, 4base, 8base (x4 for Bottleneck).
class DdppoResNetImpl : public torch::nn::Module {
 public:
  DdppoResNetImpl(int layers, int64_t inChannels, int64_t basePlanes,
                  int64_t ngroups);
  torch::Tensor forward(const torch::Tensor& x);
  /// Channels of the output map (8 * base, times 4 for ResNet-50).
  int64_t outputChannels() const { return outputChannels_; }

  torch::nn::Sequential conv1{nullptr};
  torch::nn::Sequential layer1{nullptr}, layer2{nullptr}, layer3{nullptr},
      layer4{nullptr};

 private:
  int64_t outputChannels_ = 0;
};
TORCH_MODULE(DdppoResNet);

/// DD-PPO's ResNetEncoder for depth: 2x average pool, backbone, then
/// `compression` (3x3 conv to round(2048 / s^2) channels, GroupNorm(1),
/// ReLU), s = int((imageHeight / 2) / 32). [N, 1, H, W] depth in [0, 1] ->
/// [N, C, h, w] (256x256: [N, 128, 4, 4]).
class DdppoResNetEncoderImpl : public torch::nn::Module {
 public:
  /// `layers` is 18 or 50; `imageHeight` sizes the compression (>= 64).
  DdppoResNetEncoderImpl(int layers, int64_t basePlanes, int64_t imageHeight);
  torch::Tensor forward(const torch::Tensor& x);

  DdppoResNet backbone{nullptr};
  torch::nn::Sequential compression{nullptr};
};
TORCH_MODULE(DdppoResNetEncoder);

// ---------------------------------------------------------------------------
// small CNN (CPU runs)
// ---------------------------------------------------------------------------

/// 3x3 convolutions `channels` wide with `strides` (padding 1, ReLU after
/// each) then adaptive average pooling to 4x4: [N, inChannels, H, W] ->
/// [N, channels.back(), 4, 4]. The layers are "cnn.0", "cnn.2", ... (every
/// ReLU takes an index). Throws std::invalid_argument when the lists are
/// empty, differ in length or hold a size below 1.
class SmallCnnImpl : public torch::nn::Module {
 public:
  SmallCnnImpl(int64_t inChannels, const std::vector<int>& channels,
               const std::vector<int>& strides);
  torch::Tensor forward(const torch::Tensor& x);

  torch::nn::Sequential cnn{nullptr};
};
TORCH_MODULE(SmallCnn);

}  // namespace vln::models
