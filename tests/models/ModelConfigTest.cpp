#include "models/ModelConfig.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "support/TestUtil.h"

namespace vln::models {
namespace {

using ::testing::HasSubstr;
using vln::test::errorOf;

// the config as the `model:` section of a larger file
struct Root {
  ModelConfig model;
  void visit(common::ConfigVisitor& v) { v.section("model", model, "Model"); }
  void validate() const { model.validate(); }
};

TEST(ModelConfigTest, DefaultsAreVlnCePaperSizes) {
  const ModelConfig c;
  EXPECT_EQ(c.policy, PolicyType::kCma);
  EXPECT_EQ(c.vocab_size, 2504);
  EXPECT_EQ(c.embedding_dim, 50);
  EXPECT_FALSE(c.fine_tune_embeddings);
  EXPECT_EQ(c.word_embeddings, WordEmbeddings::kGlove);
  EXPECT_EQ(c.instruction_hidden_size, 128);
  EXPECT_EQ(c.instructionStateSize(), 256);
  EXPECT_EQ(c.hidden_size, 512);
  EXPECT_EQ(c.prev_action_embedding_dim, 32);
  EXPECT_EQ(c.rgb_projection_size, 256);
  EXPECT_EQ(c.depth_projection_size, 128);
  EXPECT_EQ(c.spatial_embedding_dim, 64);
  EXPECT_EQ(c.recurrentStateRows(), 2);
  EXPECT_EQ(rgbFeatureShape(c), (FeatureShape{2048, 4, 4}));
  EXPECT_EQ(depthFeatureShape(c), (FeatureShape{128, 4, 4}));
  EXPECT_NO_THROW(c.validate());
}

TEST(ModelConfigTest, YamlRoundTripAndStrictEnums) {
  const Root r = common::loadConfigText<Root>(
      "model:\n  policy: seq2seq\n  rgb_encoder: small_cnn\n"
      "  depth_encoder: resnet18\n  no_depth: true\n  hidden_size: 64\n");
  EXPECT_EQ(r.model.policy, PolicyType::kSeq2Seq);
  EXPECT_EQ(r.model.rgb_encoder, EncoderType::kSmallCnn);
  EXPECT_EQ(r.model.depth_encoder, EncoderType::kResNet18);
  EXPECT_TRUE(r.model.no_depth);
  EXPECT_EQ(r.model.instructionStateSize(), 128);
  const Root back = common::loadConfigText<Root>(common::configToYaml(r));
  EXPECT_EQ(back.model, r.model);

  EXPECT_THAT(errorOf([] {
                common::loadConfigText<Root>("model:\n  policy: rcm\n",
                                             "m.yaml");
              }),
              HasSubstr("expected one of {seq2seq, cma}, got 'rcm'"));
  EXPECT_THAT(errorOf([] {
                common::loadConfigText<Root>("model:\n  rgb_encoder: vgg\n");
              }),
              HasSubstr("expected one of {resnet50, resnet18, small_cnn}"));
  EXPECT_EQ(common::loadConfigText<Root>("model:\n  word_embeddings: random\n")
                .model.word_embeddings,
            WordEmbeddings::kRandom);
  EXPECT_THAT(errorOf([] {
                common::loadConfigText<Root>(
                    "model:\n  word_embeddings: bert\n");
              }),
              HasSubstr("expected one of {glove, random}, got 'bert'"));
}

TEST(ModelConfigTest, RxrKeysRoundTripWithR2rDefaults) {
  const ModelConfig defaults;
  EXPECT_EQ(defaults.num_actions, 4);
  EXPECT_EQ(defaults.instruction_features, InstructionFeatures::kTokens);
  EXPECT_EQ(defaults.text_feature_dim, 768);
  EXPECT_EQ(defaults.instructionInputSize(), 50);
  const Root r = common::loadConfigText<Root>(
      "model:\n  num_actions: 6\n  instruction_features: rxr_text\n");
  EXPECT_EQ(r.model.num_actions, 6);
  EXPECT_TRUE(r.model.usesTextFeatures());
  EXPECT_EQ(r.model.instructionInputSize(), 768);
  const Root back = common::loadConfigText<Root>(common::configToYaml(r));
  EXPECT_EQ(back.model, r.model);
  EXPECT_THAT(
      errorOf([] {
        common::loadConfigText<Root>("model:\n  instruction_features: glove\n");
      }),
      HasSubstr("expected one of {tokens, rxr_text}"));
  EXPECT_THAT(errorOf([] {
                common::loadConfigText<Root>("model:\n  num_actions: 5\n");
              }),
              HasSubstr("model.num_actions must be 4 (R2R_VLNCE) or 6"));
  EXPECT_THAT(errorOf([] {
                common::loadConfigText<Root>("model:\n  num_actions: 7\n");
              }),
              HasSubstr("num_actions"));
}

TEST(ModelConfigTest, ValidateNamesFieldAndValue) {
  EXPECT_THAT(errorOf([] {
                common::loadConfigText<Root>("model:\n  depth_height: 32\n");
              }),
              HasSubstr("model.depth_height=32"));
  EXPECT_THAT(errorOf([] {
                common::loadConfigText<Root>(
                    "model:\n  no_rgb: true\n  no_depth: true\n"
                    "  no_instruction: true\n");
              }),
              HasSubstr("the policy has no input"));
  EXPECT_THAT(
      errorOf([] { common::loadConfigText<Root>("model:\n  device: gpu0\n"); }),
      HasSubstr("model.device must be cpu, cuda or cuda:N, got 'gpu0'"));
  EXPECT_THAT(errorOf([] {
                common::loadConfigText<Root>("model:\n  hidden_size: 33\n");
              }),
              HasSubstr("model.hidden_size must be even"));
  EXPECT_THAT(
      errorOf([] {
        common::loadConfigText<Root>("model:\n  depth_resnet_base_planes: 5\n");
      }),
      HasSubstr("depth_resnet_base_planes must be even"));
  EXPECT_THAT(errorOf([] {
                common::loadConfigText<Root>("model:\n  dropout: 1.0\n");
              }),
              HasSubstr("model.dropout"));
  EXPECT_THAT(errorOf([] {
                common::loadConfigText<Root>(
                    "model:\n  rgb_encoder: small_cnn\n"
                    "  rgb_cnn_channels: [32, 64]\n");
              }),
              HasSubstr("model.rgb_cnn_channels (2 layers) and "
                        "model.rgb_cnn_strides (3)"));
  EXPECT_THAT(errorOf([] {
                common::loadConfigText<Root>(
                    "model:\n  rgb_cnn_channels: [32, 64, 128]\n");
              }),
              HasSubstr("model.rgb_encoder is 'resnet50'"));
  EXPECT_THAT(errorOf([] {
                common::loadConfigText<Root>(
                    "model:\n  rgb_encoder: small_cnn\n"
                    "  rgb_cnn_strides: [2, 3, 2]\n");
              }),
              HasSubstr("model.rgb_cnn_strides"));
  // small depth images are fine for the small CNN or without depth
  EXPECT_NO_THROW(common::loadConfigText<Root>(
      "model:\n  depth_height: 32\n  depth_encoder: small_cnn\n"));
  EXPECT_NO_THROW(common::loadConfigText<Root>(
      "model:\n  depth_height: 32\n  no_depth: true\n"));
}

TEST(ModelConfigTest, DepthFeatureShapesFollowDdppoCompression) {
  ModelConfig c;
  auto at = [&](int size) {
    c.depth_height = c.depth_width = size;
    return depthFeatureShape(c);
  };
  EXPECT_EQ(at(256), (FeatureShape{128, 4, 4}));
  EXPECT_EQ(at(128), (FeatureShape{512, 2, 2}));
  EXPECT_EQ(at(64), (FeatureShape{2048, 1, 1}));
  c.depth_encoder = EncoderType::kResNet18;
  EXPECT_EQ(at(256), (FeatureShape{128, 4, 4}));
  c.depth_encoder = EncoderType::kSmallCnn;
  EXPECT_EQ(at(32), (FeatureShape{32, 4, 4}));
  c.rgb_encoder = EncoderType::kResNet18;
  EXPECT_EQ(rgbFeatureShape(c), (FeatureShape{512, 4, 4}));
  c.rgb_encoder = EncoderType::kSmallCnn;
  EXPECT_EQ(rgbFeatureShape(c), (FeatureShape{64, 4, 4}));
  c.rgb_cnn_channels = {32, 64, 64, 128};
  c.rgb_cnn_strides = {2, 2, 1, 2};
  EXPECT_EQ(rgbFeatureShape(c), (FeatureShape{128, 4, 4}));
}

}  // namespace
}  // namespace vln::models
