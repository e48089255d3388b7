#include "models/ObservationEncoder.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "ModelTestUtil.h"
#include "models/Policy.h"
#include "models/SemanticNet.h"
#include "models/StateDict.h"
#include "support/TestPaths.h"

namespace vln::models {
namespace {

using test::tinyConfig;
using ::testing::HasSubstr;
using Shape = std::vector<int64_t>;

// loading `config`'s pretrained weights fails with a message naming `file`
// and the mismatched `tensor`
void expectStrictLoadError(const ModelConfig& config, const std::string& file,
                           const std::string& tensor) {
  ObservationEncoder wrong(config);
  try {
    wrong->loadPretrained();
    ADD_FAILURE() << "expected a strict-loading error";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr(file));
    EXPECT_THAT(e.what(), HasSubstr(tensor));
  }
}

// what the encoder with semantic heads should output for images whose
// pretraining logits are `logits`: the three heads' sigmoids in order
torch::Tensor headProbabilities(const SemanticLogits& logits) {
  return torch::sigmoid(
      torch::cat({logits.categories, logits.colors, logits.room}, 1));
}

Shape sizesOf(const torch::Tensor& t) {
  return Shape(t.sizes().begin(), t.sizes().end());
}

torch::Tensor randomRgb(Shape leading, int64_t h, int64_t w) {
  leading.insert(leading.end(), {h, w, 3});
  return torch::randint(0, 256, leading, torch::kUInt8);
}

torch::Tensor randomDepth(Shape leading, int64_t h, int64_t w) {
  leading.insert(leading.end(), {h, w, 1});
  return torch::rand(leading);
}

TEST(ObservationEncoderTest, FeatureShapesMatchTheReportedShapes) {
  torch::NoGradGuard g;
  ModelConfig c = tinyConfig(PolicyType::kCma);
  ObservationEncoder small(c);
  const auto f =
      small->forward(randomRgb({3, 2}, 32, 32), randomDepth({3, 2}, 32, 32));
  const FeatureShape r = rgbFeatureShape(c), d = depthFeatureShape(c);
  EXPECT_EQ(sizesOf(f.rgb), (Shape{3, 2, r[0], r[1], r[2]}));
  EXPECT_EQ(sizesOf(f.depth), (Shape{3, 2, d[0], d[1], d[2]}));

  // paper-scale encoders on reduced images (64 px keeps the test fast)
  c.rgb_encoder = EncoderType::kResNet50;
  c.depth_encoder = EncoderType::kResNet50;
  c.rgb_height = c.rgb_width = 64;
  c.depth_height = c.depth_width = 128;
  ObservationEncoder big(c);
  const auto fb =
      big->forward(randomRgb({1}, 64, 64), randomDepth({1}, 128, 128));
  EXPECT_EQ(sizesOf(fb.rgb), (Shape{1, 2048, 4, 4}));
  EXPECT_EQ(sizesOf(fb.depth), (Shape{1, 512, 2, 2}));
  const FeatureShape db = depthFeatureShape(c);
  EXPECT_EQ(sizesOf(fb.depth), (Shape{1, db[0], db[1], db[2]}));
}

// model.rgb_batch_statistics: VLN-CE's train-mode BatchNorm while
// collecting, without touching the running statistics
TEST(ObservationEncoderTest, RgbBatchStatisticsNormaliseByTheBatchOnly) {
  torch::NoGradGuard g;
  ModelConfig c = tinyConfig(PolicyType::kCma);
  c.rgb_encoder = EncoderType::kResNet18;
  c.rgb_height = c.rgb_width = 64;
  ObservationEncoder enc(c);
  enc->eval();
  std::vector<torch::Tensor> buffers;
  for (const auto& b : enc->rgb->cnnModule().buffers()) buffers.push_back(b.clone());
  const torch::Tensor images = randomRgb({3}, 64, 64);
  const torch::Tensor running = enc->forward(images, randomDepth({3}, 32, 32)).rgb;

  enc->useRgbBatchStatistics(true);
  const torch::Tensor batch = enc->forward(images, randomDepth({3}, 32, 32)).rgb;
  // image 0 alone: another batch, other statistics
  const torch::Tensor alone =
      enc->forward(images.slice(0, 0, 1), randomDepth({1}, 32, 32)).rgb;
  EXPECT_FALSE(torch::allclose(batch, running));
  EXPECT_FALSE(torch::allclose(batch.slice(0, 0, 1), alone));
  enc->useRgbBatchStatistics(false);

  // the running statistics (and every other buffer but the batch counter)
  // are bit for bit what they were, and eval mode gives the same features
  size_t i = 0;
  for (const auto& item : enc->rgb->cnnModule().named_buffers()) {
    if (!item.key().ends_with("num_batches_tracked")) {
      EXPECT_TRUE(torch::equal(item.value(), buffers[i])) << item.key();
    }
    ++i;
  }
  EXPECT_TRUE(torch::equal(
      enc->forward(images, randomDepth({3}, 32, 32)).rgb, running));
}

TEST(ObservationEncoderTest, FrozenEncodersStayInEvalModeWithoutGradients) {
  ModelConfig c = tinyConfig(PolicyType::kCma);
  c.rgb_encoder = EncoderType::kResNet18;
  c.depth_trainable = true;
  ObservationEncoder enc(c);
  enc->train(true);
  EXPECT_FALSE(enc->rgb->is_training());
  EXPECT_TRUE(enc->depth->is_training());
  for (const auto& p : enc->rgb->parameters()) EXPECT_FALSE(p.requires_grad());
  for (const auto& p : enc->depth->parameters()) EXPECT_TRUE(p.requires_grad());
  // eval mode means BatchNorm uses (and keeps) its running statistics
  const NamedTensors before = namedState(*enc->rgb);
  std::vector<torch::Tensor> copies;
  for (const auto& [n, t] : before) copies.push_back(t.clone());
  enc->forward(randomRgb({2}, 32, 32), randomDepth({2}, 32, 32));
  for (size_t i = 0; i < before.size(); ++i)
    EXPECT_TRUE(torch::equal(before[i].second, copies[i])) << before[i].first;
}

TEST(ObservationEncoderTest, RgbNormalisationUsesImageNetStatistics) {
  // a uniform image equal to the ImageNet mean is all zeros after
  // normalisation, so a bias-free first conv layer sees nothing
  ModelConfig c = tinyConfig(PolicyType::kCma);
  c.rgb_encoder = EncoderType::kResNet18;
  RgbEncoder enc(c);
  enc->eval();
  torch::NoGradGuard g;
  torch::Tensor img = torch::empty({1, 32, 32, 3}, torch::kUInt8);
  // 0.485*255 = 123.7, 0.456*255 = 116.3, 0.406*255 = 103.5: nearest bytes
  img.select(3, 0).fill_(124);
  img.select(3, 1).fill_(116);
  img.select(3, 2).fill_(104);
  const torch::Tensor x = img.permute({0, 3, 1, 2}).to(torch::kFloat32) / 255;
  const torch::Tensor mean = torch::tensor({0.485f, 0.456f, 0.406f});
  const torch::Tensor stdev = torch::tensor({0.229f, 0.224f, 0.225f});
  const torch::Tensor expectedInput =
      (x - mean.view({1, 3, 1, 1})) / stdev.view({1, 3, 1, 1});
  const torch::Tensor expected =
      torch::adaptive_avg_pool2d(enc->resnet->forward(expectedInput), {4, 4});
  EXPECT_TRUE(torch::allclose(enc->forward(img), expected, 1e-4, 1e-5));
  EXPECT_LT(expectedInput.abs().max().item<float>(), 0.01f);
}

TEST(ObservationEncoderTest, WithoutNormalizeRgbPixelsAreDividedBy255) {
  // model.normalize_rgb: false is VLN-CE's TorchVisionResNet input
  ModelConfig c = tinyConfig(PolicyType::kCma);
  c.rgb_encoder = EncoderType::kResNet18;
  c.normalize_rgb = false;
  torch::manual_seed(31);
  RgbEncoder plain(c);
  c.normalize_rgb = true;
  RgbEncoder imageNet(c);
  loadStateStrict(*imageNet, namedState(*plain));
  plain->eval();
  imageNet->eval();
  torch::NoGradGuard g;
  const torch::Tensor img =
      torch::randint(0, 256, {2, 32, 32, 3}, torch::kUInt8);
  const torch::Tensor x = img.permute({0, 3, 1, 2}).to(torch::kFloat32) / 255;
  const torch::Tensor expected =
      torch::adaptive_avg_pool2d(plain->resnet->forward(x), {4, 4});
  EXPECT_TRUE(torch::allclose(plain->forward(img), expected, 1e-5, 1e-6));
  EXPECT_FALSE(plain->normalizesWithImageNet());
  EXPECT_TRUE(imageNet->normalizesWithImageNet());
  EXPECT_FALSE(torch::allclose(imageNet->forward(img), expected, 1e-3, 1e-3));
}

TEST(ObservationEncoderTest, AblatedModalitiesHaveNoEncoder) {
  ModelConfig c = tinyConfig(PolicyType::kSeq2Seq);
  c.no_rgb = true;
  ObservationEncoder enc(c);
  EXPECT_FALSE(enc->rgb);
  const auto f = enc->forward({}, randomDepth({2}, 32, 32));
  EXPECT_FALSE(f.rgb.defined());
  EXPECT_TRUE(f.depth.defined());
  EXPECT_THROW(enc->forward({}, {}), c10::Error);
}

TEST(ObservationEncoderTest, PretrainedWeightsLoadStrictly) {
  torch::manual_seed(5);
  ModelConfig c = tinyConfig(PolicyType::kCma);
  ObservationEncoder source(c);
  vln::test::TempDir dir;
  saveModule(source->rgb->cnnModule(), dir / "rgb.pt");
  saveModule(source->depth->cnnModule(), dir / "depth.pt");
  c.rgb_weights = (dir / "rgb.pt").string();
  c.depth_weights = (dir / "depth.pt").string();
  ObservationEncoder loaded(c);
  loaded->loadPretrained();
  const torch::Tensor rgb = randomRgb({2}, 32, 32);
  const torch::Tensor depth = randomDepth({2}, 32, 32);
  torch::NoGradGuard g;
  const auto a = source->forward(rgb, depth);
  const auto b = loaded->forward(rgb, depth);
  EXPECT_TRUE(torch::equal(a.rgb, b.rgb));
  EXPECT_TRUE(torch::equal(a.depth, b.depth));

  // an RGB file given for the depth CNN fails and names the file
  c.depth_weights = c.rgb_weights;
  expectStrictLoadError(
      c, "rgb.pt", "cnn.0.weight expected [32, 1, 3, 3], got [32, 3, 3, 3]");
}

TEST(ObservationEncoderTest,
     SemanticOutputsAreThePretrainedHeadsProbabilities) {
  torch::manual_seed(6);
  ModelConfig c = tinyConfig(PolicyType::kCma);
  c.no_depth = true;
  SemanticNet net(c, /*categories=*/7, /*colors=*/5, /*rooms=*/3);
  vln::test::TempDir dir;
  saveModule(*net, dir / "semantic_net.pt");
  c.rgb_semantic_outputs = 15;
  c.rgb_weights = (dir / "semantic_net.pt").string();
  EXPECT_EQ(rgbFeatureShape(c), (FeatureShape{15, 1, 1}));
  ObservationEncoder encoder(c);
  encoder->loadPretrained();
  const torch::Tensor rgb = randomRgb({2, 3}, 32, 32);
  torch::NoGradGuard g;
  const torch::Tensor features = encoder->forward(rgb, {}).rgb;
  EXPECT_EQ(sizesOf(features), (Shape{2, 3, 15, 1, 1}));
  const SemanticLogits logits = net->forward(rgb.reshape({6, 32, 32, 3}));
  const torch::Tensor expected =
      headProbabilities(logits).view({2, 3, 15, 1, 1});
  EXPECT_TRUE(torch::allclose(features, expected, 1e-5, 1e-6));
  // frozen like the CNN
  for (const auto& p : encoder->rgb->semantic->parameters())
    EXPECT_FALSE(p.requires_grad());

  // heads of another size, a file of the CNN alone, no file: named errors
  auto expectError = [&](ModelConfig bad, const std::string& what) {
    ObservationEncoder e(bad);
    try {
      e->loadPretrained();
      ADD_FAILURE() << "no error, expected: " << what;
    } catch (const std::invalid_argument& error) {
      EXPECT_THAT(error.what(), HasSubstr(what));
    }
  };
  ModelConfig wider = c;
  wider.rgb_semantic_outputs = 16;
  expectError(wider,
              "model.rgb_semantic_outputs is 16 but the heads of '" +
                  c.rgb_weights +
                  "' have 15 outputs (categories 7, colours 5, rooms 3)");
  saveModule(net->rgb->cnnModule(), dir / "cnn.pt");
  ModelConfig cnnOnly = c;
  cnnOnly.rgb_weights = (dir / "cnn.pt").string();
  expectError(cnnOnly, "cnn.pt");
  ModelConfig none = c;
  none.rgb_weights.clear();
  expectError(none, "model.rgb_weights is empty");

  // the low-level policies read the CNN's feature map only
  EXPECT_THAT([&] { makePolicy(c); },
              ::testing::ThrowsMessage<std::invalid_argument>(
                  HasSubstr("read by the waypoint CMA only")));
  c.no_rgb = true;
  c.no_depth = false;
  EXPECT_NO_THROW(makePolicy(c));
}

TEST(ObservationEncoderTest, SemanticHeadsOnADeeperSmallCnnLoadWithItsShape) {
  torch::manual_seed(7);
  ModelConfig c = tinyConfig(PolicyType::kCma);
  c.no_depth = true;
  c.rgb_cnn_channels = {8, 8, 16, 16};
  c.rgb_cnn_strides = {2, 1, 2, 2};
  SemanticNet net(c, /*categories=*/7, /*colors=*/5, /*rooms=*/3);
  vln::test::TempDir dir;
  saveModule(*net, dir / "semantic_net.pt");
  c.rgb_semantic_outputs = 15;
  c.rgb_weights = (dir / "semantic_net.pt").string();
  ObservationEncoder encoder(c);
  encoder->loadPretrained();
  const torch::Tensor rgb = randomRgb({1, 2}, 32, 32);
  torch::NoGradGuard g;
  const SemanticLogits logits = net->forward(rgb.reshape({2, 32, 32, 3}));
  EXPECT_TRUE(torch::allclose(encoder->forward(rgb, {}).rgb,
                              headProbabilities(logits).view({1, 2, 15, 1, 1}),
                              1e-5, 1e-6));
  // the agent's config must shape the CNN as the pretraining did
  ModelConfig shallow = c;
  shallow.rgb_cnn_channels = kSmallCnnRgbChannels;
  shallow.rgb_cnn_strides = kSmallCnnStrides;
  expectStrictLoadError(
      shallow, "semantic_net.pt",
      "cnn.0.weight expected [32, 3, 3, 3], got [8, 3, 3, 3]");
}

}  // namespace
}  // namespace vln::models
