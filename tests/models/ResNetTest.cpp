// Backbone layouts: parameter names, counts and output shapes of
// torchvision's and DD-PPO's ResNets, which converted weights depend on.
#include "models/ResNet.h"

#include <gtest/gtest.h>

#include <map>

#include "models/ModelConfig.h"
#include "models/StateDict.h"

namespace vln::models {
namespace {

using Shape = std::vector<int64_t>;

std::map<std::string, Shape> shapes(torch::nn::Module& m) {
  std::map<std::string, Shape> out;
  for (const auto& [name, t] : namedState(m))
    out[name] = Shape(t.sizes().begin(), t.sizes().end());
  return out;
}

int64_t parameterCount(torch::nn::Module& m) {
  int64_t n = 0;
  for (const auto& p : m.parameters()) n += p.numel();
  return n;
}

Shape sizesOf(const torch::Tensor& t) {
  return Shape(t.sizes().begin(), t.sizes().end());
}

TEST(ResNetTest, TorchVisionResNet50MatchesTorchvisionStateDict) {
  TorchVisionResNet net(50);
  const auto s = shapes(*net);
  // torchvision resnet50: 320 state_dict entries and 25,557,032 parameters,
  // of which fc.weight/fc.bias (2,049,000) are not part of the backbone
  EXPECT_EQ(s.size(), 318u);
  EXPECT_EQ(parameterCount(*net), 25557032 - 2049000);
  EXPECT_EQ(s.at("conv1.weight"), (Shape{64, 3, 7, 7}));
  EXPECT_EQ(s.at("bn1.running_var"), (Shape{64}));
  EXPECT_EQ(s.at("layer1.0.downsample.0.weight"), (Shape{256, 64, 1, 1}));
  EXPECT_EQ(s.at("layer2.0.conv2.weight"), (Shape{128, 128, 3, 3}));
  EXPECT_EQ(s.at("layer4.2.bn3.num_batches_tracked"), (Shape{}));
  EXPECT_EQ(net->outputChannels(), 2048);
  net->eval();
  torch::NoGradGuard g;
  EXPECT_EQ(sizesOf(net->forward(torch::rand({1, 3, 64, 64}))),
            (Shape{1, 2048, 2, 2}));
}

TEST(ResNetTest, TorchVisionResNet18MatchesTorchvisionStateDict) {
  TorchVisionResNet net(18);
  const auto s = shapes(*net);
  // torchvision resnet18: 122 entries, 11,689,512 parameters (fc: 513,000)
  EXPECT_EQ(s.size(), 120u);
  EXPECT_EQ(parameterCount(*net), 11689512 - 513000);
  EXPECT_EQ(s.at("layer3.0.downsample.1.running_mean"), (Shape{256}));
  EXPECT_EQ(s.count("layer1.0.conv3.weight"), 0u);
  net->eval();
  torch::NoGradGuard g;
  EXPECT_EQ(sizesOf(net->forward(torch::rand({2, 3, 64, 96}))),
            (Shape{2, 512, 2, 3}));
}

TEST(ResNetTest, DdppoResNet50MatchesCheckpointLayout) {
  DdppoResNetEncoder net(50, /*basePlanes=*/32, /*imageHeight=*/256);
  const auto s = shapes(*net);
  // GroupNorm has no buffers: stem 3 + 16 bottlenecks x 9 + 4 downsamples
  // x 3 + compression 3
  EXPECT_EQ(s.size(), 162u);
  EXPECT_EQ(s.at("backbone.conv1.0.weight"), (Shape{32, 1, 7, 7}));
  EXPECT_EQ(s.at("backbone.conv1.1.weight"), (Shape{32}));
  EXPECT_EQ(s.at("backbone.layer1.0.convs.0.weight"), (Shape{32, 32, 1, 1}));
  EXPECT_EQ(s.at("backbone.layer1.0.convs.4.bias"), (Shape{32}));
  EXPECT_EQ(s.at("backbone.layer1.0.convs.6.weight"), (Shape{128, 32, 1, 1}));
  EXPECT_EQ(s.at("backbone.layer1.0.downsample.0.weight"),
            (Shape{128, 32, 1, 1}));
  EXPECT_EQ(s.at("backbone.layer2.0.convs.3.weight"), (Shape{64, 64, 3, 3}));
  EXPECT_EQ(s.at("backbone.layer4.2.convs.7.weight"), (Shape{1024}));
  EXPECT_EQ(s.at("compression.0.weight"), (Shape{128, 1024, 3, 3}));
  EXPECT_EQ(s.at("compression.1.weight"), (Shape{128}));
  const auto& gn = *net->backbone->layer1[0]
                        ->as<DdppoBlock>()
                        ->convs[1]
                        ->as<torch::nn::GroupNorm>();
  EXPECT_EQ(gn.options.num_groups(), 16);
  torch::NoGradGuard g;
  EXPECT_EQ(sizesOf(net->forward(torch::rand({1, 1, 256, 256}))),
            (Shape{1, 128, 4, 4}));
}

TEST(ResNetTest, DdppoCompressionAdaptsToImageSize) {
  torch::NoGradGuard g;
  DdppoResNetEncoder at128(50, 32, 128);
  EXPECT_EQ(sizesOf(at128->forward(torch::rand({2, 1, 128, 128}))),
            (Shape{2, 512, 2, 2}));
  DdppoResNetEncoder at64(18, 32, 64);
  EXPECT_EQ(sizesOf(at64->forward(torch::rand({1, 1, 64, 64}))),
            (Shape{1, 2048, 1, 1}));
  EXPECT_EQ(at64->backbone->outputChannels(), 256);
  EXPECT_THROW(DdppoResNetEncoder(50, 32, 32), std::invalid_argument);
  EXPECT_THROW(DdppoResNetEncoder(34, 32, 256), std::invalid_argument);
}

TEST(ResNetTest, SmallCnnPoolsToFourByFour) {
  SmallCnn net(3, kSmallCnnRgbChannels, kSmallCnnStrides);
  EXPECT_EQ(sizesOf(net->forward(torch::rand({2, 3, 32, 32}))),
            (Shape{2, 64, 4, 4}));
  EXPECT_EQ(sizesOf(net->forward(torch::rand({1, 3, 50, 70}))),
            (Shape{1, 64, 4, 4}));
}

TEST(ResNetTest, SmallCnnDrawsItsLastLayerFirst) {
  // the order of the three-layer CNN before its layers became
  // configurable: a seed's first draws are the last layer's, so earlier
  // runs' numbers reproduce
  torch::manual_seed(5);
  SmallCnn net(3, kSmallCnnRgbChannels, kSmallCnnStrides);
  torch::manual_seed(5);
  torch::nn::Conv2d last(
      torch::nn::Conv2dOptions(64, 64, 3).stride(2).padding(1).bias(true));
  const auto params = net->named_parameters();
  EXPECT_TRUE(torch::equal(params["cnn.4.weight"], last->weight));
  EXPECT_TRUE(torch::equal(params["cnn.4.bias"], last->bias));
}

TEST(ResNetTest, SmallCnnLayersAreTheListedWidthsAndStrides) {
  using Ints = std::vector<int>;
  SmallCnn net(3, Ints{8, 16, 16, 24}, Ints{2, 1, 2, 1});
  // the checkpoint names of the default three layers carry over: convs at
  // the even indices, a ReLU after each
  const auto params = net->named_parameters();
  ASSERT_TRUE(params.contains("cnn.6.weight"));
  EXPECT_EQ(sizesOf(params["cnn.0.weight"]), (Shape{8, 3, 3, 3}));
  EXPECT_EQ(sizesOf(params["cnn.2.weight"]), (Shape{16, 8, 3, 3}));
  EXPECT_EQ(sizesOf(params["cnn.6.weight"]), (Shape{24, 16, 3, 3}));
  EXPECT_EQ(params.size(), 8u);
  // strides 2, 1, 2, 1: 64 px -> 16 px before the pooling; a stride-1 layer
  // keeps the size (a 16 px map from 32 px with the default strides would
  // be 4 px)
  const torch::Tensor maps = net->cnn->forward(torch::rand({1, 3, 64, 64}));
  EXPECT_EQ(sizesOf(maps), (Shape{1, 24, 16, 16}));
  EXPECT_EQ(sizesOf(net->forward(torch::rand({2, 3, 64, 64}))),
            (Shape{2, 24, 4, 4}));
  EXPECT_THROW(SmallCnn(3, Ints{8, 16}, Ints{2}), std::invalid_argument);
  EXPECT_THROW(SmallCnn(3, Ints{}, Ints{}), std::invalid_argument);
  EXPECT_THROW(SmallCnn(3, Ints{8, 0}, Ints{2, 2}), std::invalid_argument);
}

}  // namespace
}  // namespace vln::models
