// The text encoder of RxR's instruction features made here: shapes, zero
// PAD rows, batch independence, the masking draw and a save/load round trip.

#include "models/TextFeatureEncoder.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "models/StateDict.h"
#include "support/TestPaths.h"

namespace vln::models {
namespace {

// tiny and pairwise distinct sizes
TextEncoderConfig tinyTextConfig() {
  TextEncoderConfig c;
  c.hidden_size = 12;
  c.layers = 2;
  c.heads = 3;
  c.ff_size = 20;
  c.output_dim = 24;
  c.max_tokens = 16;
  c.dropout = 0.1;
  return c;
}

constexpr int64_t kVocab = 17;

TEST(TextFeatureEncoderTest, ShapesAndZeroPadRows) {
  torch::manual_seed(0);
  TextFeatureEncoder encoder(tinyTextConfig(), kVocab);
  encoder->eval();
  const torch::Tensor tokens =
      torch::tensor({{3, 4, 5, 6, 7}, {8, 9, 0, 0, 0}}, torch::kInt64);
  const torch::Tensor features = encoder->forward(tokens);
  EXPECT_EQ(features.sizes(), (std::vector<int64_t>{2, 5, 24}));
  EXPECT_EQ(features.scalar_type(), torch::kFloat32);
  // PAD rows are exactly zero, real rows are not (RxR's zero padding)
  EXPECT_EQ(features[1].slice(0, 2).abs().max().item<float>(), 0.0f);
  EXPECT_GT(features[1].slice(0, 0, 2).abs().sum(1).min().item<float>(), 0.0f);
  EXPECT_GT(features[0].abs().sum(1).min().item<float>(), 0.0f);
  EXPECT_EQ(encoder->mlmLogits(features).sizes(),
            (std::vector<int64_t>{2, 5, kVocab}));
}

TEST(TextFeatureEncoderTest, FeaturesDoNotDependOnTheBatch) {
  torch::manual_seed(1);
  TextFeatureEncoder encoder(tinyTextConfig(), kVocab);
  encoder->eval();
  torch::NoGradGuard noGrad;
  const torch::Tensor batched = encoder->forward(
      torch::tensor({{3, 4, 5, 6, 7, 8}, {9, 10, 11, 0, 0, 0}}, torch::kInt64));
  const torch::Tensor alone = encoder->encodeOne({9, 10, 11});
  EXPECT_EQ(alone.sizes(), (std::vector<int64_t>{3, 24}));
  EXPECT_TRUE(torch::allclose(alone, batched[1].slice(0, 0, 3), 1e-5, 1e-5));
  // a row's context matters: the same word elsewhere gets other features
  const torch::Tensor other = encoder->encodeOne({9, 12, 11});
  EXPECT_FALSE(torch::allclose(other[0], alone[0], 1e-4, 1e-4));
  // encodeOne() is repeatable and leaves the training mode alone
  encoder->train();
  EXPECT_TRUE(torch::equal(encoder->encodeOne({9, 10, 11}), alone));
  EXPECT_TRUE(encoder->is_training());
}

TEST(TextFeatureEncoderTest, RejectsBadTokens) {
  TextFeatureEncoder encoder(tinyTextConfig(), kVocab);
  EXPECT_THROW(encoder->forward(torch::full({1, 17}, 3, torch::kInt64)),
               c10::Error);
  EXPECT_THROW(encoder->forward(torch::tensor({{3, kVocab}}, torch::kInt64)),
               c10::Error);
  EXPECT_THROW(encoder->encodeOne({}), c10::Error);
  EXPECT_THROW(encoder->encodeOne({3, 0, 4}), c10::Error);
  TextEncoderConfig bad = tinyTextConfig();
  bad.heads = 5;
  EXPECT_THROW(TextFeatureEncoder(bad, kVocab), std::invalid_argument);
}

TEST(TextFeatureEncoderTest, MaskingFollowsBertAndTheSeed) {
  // 200 rows of 40 real tokens and 10 PAD
  torch::Tensor tokens = torch::randint(2, 50, {200, 50}, torch::kInt64);
  tokens.slice(1, 40).zero_();
  MlmMaskOptions options;
  options.mask_index = 60;
  options.random_low = 2;
  options.random_high = 50;
  std::mt19937_64 rng(7);
  const MlmBatch batch = maskTokens(tokens, options, rng);
  const torch::Tensor chosen = batch.labels.ne(kMlmIgnore);
  // PAD is never chosen; labels hold the original ids where chosen
  EXPECT_EQ(chosen.slice(1, 40).sum().item<int64_t>(), 0);
  EXPECT_TRUE(torch::equal(batch.labels.masked_select(chosen),
                           tokens.masked_select(chosen)));
  EXPECT_TRUE(torch::equal(batch.inputs.masked_select(~chosen),
                           tokens.masked_select(~chosen)));
  // 15% of 8000 tokens, of which 80% <mask> (binomial, +-5 sigma)
  const double n = chosen.sum().item<double>();
  EXPECT_NEAR(n / 8000.0, 0.15, 5 * std::sqrt(0.15 * 0.85 / 8000.0));
  const double masked = batch.inputs.eq(60).sum().item<double>();
  EXPECT_NEAR(masked / n, 0.8, 5 * std::sqrt(0.8 * 0.2 / n));
  EXPECT_EQ(batch.inputs.ge(50)
                .logical_and(batch.inputs.ne(60))
                .sum()
                .item<int64_t>(),
            0);
  // the same seed draws the same batch
  std::mt19937_64 again(7);
  const MlmBatch repeat = maskTokens(tokens, options, again);
  EXPECT_TRUE(torch::equal(repeat.inputs, batch.inputs));
  EXPECT_TRUE(torch::equal(repeat.labels, batch.labels));
  // probability 1 and replace_mask 1: every real token becomes <mask>
  options.probability = 1.0;
  options.replace_mask = 1.0;
  const MlmBatch all = maskTokens(tokens, options, rng);
  EXPECT_EQ(all.inputs.eq(60).sum().item<int64_t>(), 8000);
}

TEST(TextFeatureEncoderTest, PadTokenRows) {
  const torch::Tensor rows = padTokenRows({{3, 4}, {5}, {6, 7, 8}});
  EXPECT_TRUE(torch::equal(
      rows, torch::tensor({{3, 4, 0}, {5, 0, 0}, {6, 7, 8}}, torch::kInt64)));
}

TEST(TextFeatureEncoderTest, SaveLoadRoundTrip) {
  vln::test::TempDir dir;
  torch::manual_seed(2);
  TextFeatureEncoder encoder(tinyTextConfig(), kVocab);
  saveModule(*encoder, dir / "text.pt");
  torch::manual_seed(3);
  TextFeatureEncoder loaded(tinyTextConfig(), kVocab);
  loadModule(*loaded, dir / "text.pt");
  EXPECT_TRUE(torch::equal(encoder->encodeOne({3, 4, 5}),
                           loaded->encodeOne({3, 4, 5})));
  // another vocabulary does not fit
  TextFeatureEncoder other(tinyTextConfig(), kVocab + 1);
  EXPECT_THROW(loadModule(*other, dir / "text.pt"), std::invalid_argument);
}

TEST(TextFeatureEncoderTest, GradientsReachEveryParameter) {
  torch::manual_seed(4);
  TextEncoderConfig config = tinyTextConfig();
  config.dropout = 0.0;
  TextFeatureEncoder encoder(config, kVocab);
  const torch::Tensor tokens =
      torch::tensor({{3, 4, 5, 6}, {7, 8, 0, 0}}, torch::kInt64);
  const torch::Tensor logits = encoder->mlmLogits(encoder->forward(tokens));
  torch::nn::functional::cross_entropy(
      logits.reshape({-1, kVocab}),
      torch::tensor(
          std::vector<int64_t>{5, 6, 7, 8, 9, 10, kMlmIgnore, kMlmIgnore}),
      torch::nn::functional::CrossEntropyFuncOptions().ignore_index(kMlmIgnore))
      .backward();
  for (const auto& p : encoder->named_parameters()) {
    ASSERT_TRUE(p.value().grad().defined()) << p.key();
    EXPECT_TRUE(torch::isfinite(p.value().grad()).all().item<bool>())
        << p.key();
  }
  // PAD's embedding row gets no gradient (padding_idx 0)
  EXPECT_EQ(encoder->tokenEmbedding->weight.grad()[0].abs().sum().item<float>(),
            0.0f);
}

}  // namespace
}  // namespace vln::models
