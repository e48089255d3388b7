#include "models/ResNet.h"

#include <cmath>

#include "common/Check.h"

namespace vln::models {
namespace {

namespace nn = torch::nn;

nn::Conv2d conv(int64_t in, int64_t out, int64_t kernel, int64_t stride,
                int64_t padding, bool bias = false) {
  return nn::Conv2d(nn::Conv2dOptions(in, out, kernel)
                        .stride(stride)
                        .padding(padding)
                        .bias(bias));
}

// blocks per stage: torchvision and habitat use the same counts
std::array<int64_t, 4> stageBlocks(int layers) {
  VLN_CHECK_ARG(layers == 18 || layers == 50,
                "ResNet: only ResNet-18 and ResNet-50 exist here, got ",
                layers);
  if (layers == 18) return {2, 2, 2, 2};
  return {3, 4, 6, 3};
}

// both ResNets after their stem: the 3x3/2 max pool, then the four stages
torch::Tensor poolAndStages(const torch::Tensor& stem, nn::Sequential& layer1,
                            nn::Sequential& layer2, nn::Sequential& layer3,
                            nn::Sequential& layer4) {
  torch::Tensor out = torch::max_pool2d(stem, /*kernel_size=*/3, /*stride=*/2,
                                        /*padding=*/1);
  out = layer1->forward(out);
  out = layer2->forward(out);
  out = layer3->forward(out);
  return layer4->forward(out);
}

}  // namespace

// ===========================================================================
// torchvision ResNet
// ===========================================================================

TvBlockImpl::TvBlockImpl(int64_t inplanes, int64_t planes, int64_t stride,
                         bool bottleneck)
    : bottleneck(bottleneck) {
  const int64_t expansion = bottleneck ? 4 : 1;
  if (bottleneck) {
    // torchvision >= 0.3 (ResNet v1.5) puts the stride on the 3x3 conv
    conv1 = register_module("conv1", conv(inplanes, planes, 1, 1, 0));
    bn1 = register_module("bn1", nn::BatchNorm2d(planes));
    conv2 = register_module("conv2", conv(planes, planes, 3, stride, 1));
    bn2 = register_module("bn2", nn::BatchNorm2d(planes));
    conv3 = register_module("conv3", conv(planes, planes * 4, 1, 1, 0));
    bn3 = register_module("bn3", nn::BatchNorm2d(planes * 4));
  } else {
    conv1 = register_module("conv1", conv(inplanes, planes, 3, stride, 1));
    bn1 = register_module("bn1", nn::BatchNorm2d(planes));
    conv2 = register_module("conv2", conv(planes, planes, 3, 1, 1));
    bn2 = register_module("bn2", nn::BatchNorm2d(planes));
  }
  if (stride != 1 || inplanes != planes * expansion) {
    downsample = register_module(
        "downsample",
        nn::Sequential(conv(inplanes, planes * expansion, 1, stride, 0),
                       nn::BatchNorm2d(planes * expansion)));
  }
}

torch::Tensor TvBlockImpl::forward(const torch::Tensor& x) {
  torch::Tensor out = torch::relu(bn1(conv1(x)));
  if (bottleneck) {
    out = torch::relu(bn2(conv2(out)));
    out = bn3(conv3(out));
  } else {
    out = bn2(conv2(out));
  }
  const torch::Tensor identity = downsample ? downsample->forward(x) : x;
  return torch::relu(out + identity);
}

TorchVisionResNetImpl::TorchVisionResNetImpl(int layers) {
  const auto blocks = stageBlocks(layers);
  const bool bottleneck = layers == 50;
  const int64_t expansion = bottleneck ? 4 : 1;
  conv1 = register_module("conv1", conv(3, 64, 7, 2, 3));
  bn1 = register_module("bn1", nn::BatchNorm2d(64));
  int64_t inplanes = 64;
  auto makeStage = [&](int64_t planes, int64_t count, int64_t stride) {
    nn::Sequential stage;
    for (int64_t i = 0; i < count; ++i) {
      stage->push_back(
          TvBlock(inplanes, planes, i == 0 ? stride : 1, bottleneck));
      inplanes = planes * expansion;
    }
    return stage;
  };
  layer1 = register_module("layer1", makeStage(64, blocks[0], 1));
  layer2 = register_module("layer2", makeStage(128, blocks[1], 2));
  layer3 = register_module("layer3", makeStage(256, blocks[2], 2));
  layer4 = register_module("layer4", makeStage(512, blocks[3], 2));
  outputChannels_ = inplanes;

  // torchvision's initialisation (used when no ImageNet weights are given)
  for (auto& module : modules(/*include_self=*/false)) {
    if (auto* c = module->as<nn::Conv2d>()) {
      nn::init::kaiming_normal_(c->weight, /*a=*/0, torch::kFanOut,
                                torch::kReLU);
    } else if (auto* bn = module->as<nn::BatchNorm2d>()) {
      nn::init::ones_(bn->weight);
      nn::init::zeros_(bn->bias);
    }
  }
}

torch::Tensor TorchVisionResNetImpl::forward(const torch::Tensor& x) {
  return poolAndStages(torch::relu(bn1(conv1(x))), layer1, layer2, layer3,
                       layer4);
}

// ===========================================================================
// DD-PPO ResNet
// ===========================================================================

DdppoBlockImpl::DdppoBlockImpl(int64_t inplanes, int64_t planes,
                               int64_t ngroups, int64_t stride,
                               bool bottleneck) {
  const int64_t expansion = bottleneck ? 4 : 1;
  // the ReLUs are Sequential entries so that the GroupNorm indices (1, 4, 7)
  // match the DD-PPO checkpoint's parameter names
  if (bottleneck) {
    convs = register_module(
        "convs", nn::Sequential(conv(inplanes, planes, 1, 1, 0),
                                nn::GroupNorm(ngroups, planes), nn::ReLU(),
                                conv(planes, planes, 3, stride, 1),
                                nn::GroupNorm(ngroups, planes), nn::ReLU(),
                                conv(planes, planes * 4, 1, 1, 0),
                                nn::GroupNorm(ngroups, planes * 4)));
  } else {
    convs = register_module(
        "convs", nn::Sequential(conv(inplanes, planes, 3, stride, 1),
                                nn::GroupNorm(ngroups, planes), nn::ReLU(),
                                conv(planes, planes, 3, 1, 1),
                                nn::GroupNorm(ngroups, planes)));
  }
  if (stride != 1 || inplanes != planes * expansion) {
    downsample = register_module(
        "downsample",
        nn::Sequential(conv(inplanes, planes * expansion, 1, stride, 0),
                       nn::GroupNorm(ngroups, planes * expansion)));
  }
}

torch::Tensor DdppoBlockImpl::forward(const torch::Tensor& x) {
  const torch::Tensor identity = downsample ? downsample->forward(x) : x;
  return torch::relu(convs->forward(x) + identity);
}

DdppoResNetImpl::DdppoResNetImpl(int layers, int64_t inChannels,
                                 int64_t basePlanes, int64_t ngroups) {
  const auto blocks = stageBlocks(layers);
  const bool bottleneck = layers == 50;
  const int64_t expansion = bottleneck ? 4 : 1;
  conv1 = register_module(
      "conv1", nn::Sequential(conv(inChannels, basePlanes, 7, 2, 3),
                              nn::GroupNorm(ngroups, basePlanes), nn::ReLU()));
  int64_t inplanes = basePlanes;
  auto makeStage = [&](int64_t planes, int64_t count, int64_t stride) {
    nn::Sequential stage;
    for (int64_t i = 0; i < count; ++i) {
      stage->push_back(DdppoBlock(inplanes, planes, ngroups,
                                  i == 0 ? stride : 1, bottleneck));
      inplanes = planes * expansion;
    }
    return stage;
  };
  layer1 = register_module("layer1", makeStage(basePlanes, blocks[0], 1));
  layer2 = register_module("layer2", makeStage(basePlanes * 2, blocks[1], 2));
  layer3 = register_module("layer3", makeStage(basePlanes * 4, blocks[2], 2));
  layer4 = register_module("layer4", makeStage(basePlanes * 8, blocks[3], 2));
  outputChannels_ = inplanes;
}

torch::Tensor DdppoResNetImpl::forward(const torch::Tensor& x) {
  return poolAndStages(conv1->forward(x), layer1, layer2, layer3, layer4);
}

DdppoResNetEncoderImpl::DdppoResNetEncoderImpl(int layers, int64_t basePlanes,
                                               int64_t imageHeight) {
  VLN_CHECK_ARG(basePlanes >= 2 && basePlanes % 2 == 0,
                "DdppoResNetEncoder: base width must be even (ngroups = base "
                "/ 2), got ",
                basePlanes);
  const int64_t finalSpatial = (imageHeight / 2) / 32;
  VLN_CHECK_ARG(finalSpatial >= 1,
                "DdppoResNetEncoder: depth images must be at least 64 px "
                "high, got ",
                imageHeight);
  backbone = register_module(
      "backbone",
      DdppoResNet(layers, /*inChannels=*/1, basePlanes, basePlanes / 2));
  // ResNetEncoder aims at 2048 values after compression, whatever the size
  const int64_t channels =
      std::llround(2048.0 / static_cast<double>(finalSpatial * finalSpatial));
  compression = register_module(
      "compression",
      nn::Sequential(conv(backbone->outputChannels(), channels, 3, 1, 1),
                     nn::GroupNorm(1, channels), nn::ReLU()));
}

torch::Tensor DdppoResNetEncoderImpl::forward(const torch::Tensor& x) {
  const torch::Tensor pooled = torch::avg_pool2d(x, /*kernel_size=*/2);
  return compression->forward(backbone->forward(pooled));
}

// ===========================================================================
// small CNN
// ===========================================================================

SmallCnnImpl::SmallCnnImpl(int64_t inChannels, const std::vector<int>& channels,
                           const std::vector<int>& strides) {
  VLN_CHECK_ARG(!channels.empty() && channels.size() == strides.size(),
                "SmallCnn: ", channels.size(), " layer widths and ",
                strides.size(), " strides");
  for (size_t i = 0; i < channels.size(); ++i)
    VLN_CHECK_ARG(channels[i] >= 1 && strides[i] >= 1, "SmallCnn: layer ", i,
                  " has width ", channels[i], " and stride ", strides[i]);
  // the layers are initialised last to first: the order in which the
  // three-layer CNN's constructor arguments were evaluated before the
  // layers became configurable, so that a run from a seed draws the
  // weights it drew then and reproduces its documented numbers
  std::vector<nn::Conv2d> convs(channels.size(), nullptr);
  for (size_t i = channels.size(); i-- > 0;)
    convs[i] = conv(i == 0 ? inChannels : channels[i - 1], channels[i], 3,
                    strides[i], 1, /*bias=*/true);
  nn::Sequential layers;
  for (const nn::Conv2d& c : convs) {
    layers->push_back(c);
    layers->push_back(nn::ReLU());
  }
  cnn = register_module("cnn", layers);
}

torch::Tensor SmallCnnImpl::forward(const torch::Tensor& x) {
  return torch::adaptive_avg_pool2d(cnn->forward(x), {4, 4});
}

}  // namespace vln::models
