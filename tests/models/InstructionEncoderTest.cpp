#include "models/InstructionEncoder.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "ModelTestUtil.h"
#include "common/Json.h"
#include "support/TestPaths.h"
#include "support/TestUtil.h"

namespace vln::models {
namespace {

using test::randomTokens;
using test::tinyConfig;
using ::testing::HasSubstr;
using vln::test::errorOf;

TEST(InstructionEncoderTest, BidirectionalForCmaUnidirectionalForSeq2Seq) {
  torch::manual_seed(0);
  InstructionEncoder cma(tinyConfig(PolicyType::kCma));
  InstructionEncoder s2s(tinyConfig(PolicyType::kSeq2Seq));
  const torch::Tensor tokens = randomTokens({4, 2, 6}, 8, 23);
  const auto a = cma->forward(tokens);
  EXPECT_EQ(a.states.sizes(), (std::vector<int64_t>{3, 6, 10}));
  EXPECT_EQ(a.mask.sizes(), (std::vector<int64_t>{3, 6}));
  EXPECT_EQ(a.last.sizes(), (std::vector<int64_t>{3, 5}));
  const auto b = s2s->forward(tokens);
  EXPECT_EQ(b.states.sizes(), (std::vector<int64_t>{3, 6, 5}));
  // the final state is the forward state at the last real token
  for (int64_t row = 0; row < 3; ++row) {
    const int64_t len = tokens[row].ne(0).sum().item<int64_t>();
    EXPECT_TRUE(torch::allclose(b.last[row], b.states[row][len - 1]));
    EXPECT_TRUE(b.mask[row].slice(0, 0, len).all().item<bool>());
    EXPECT_FALSE(b.mask[row].slice(0, len).any().item<bool>());
    EXPECT_EQ(b.states[row].slice(0, len).abs().sum().item<float>(), 0.0f);
  }
}

TEST(InstructionEncoderTest, PaddingAndBatchCompanionsNeverChangeARow) {
  torch::manual_seed(1);
  InstructionEncoder enc(tinyConfig(PolicyType::kCma));
  const torch::Tensor row = randomTokens({5}, 5, 23);
  const auto alone = enc->forward(row);
  // same row, padded to 12 and batched with a longer instruction
  torch::Tensor batch = torch::zeros({2, 12}, torch::kInt64);
  batch[0].slice(0, 0, 5).copy_(row[0]);
  batch[1].copy_(randomTokens({12}, 12, 23)[0]);
  const auto both = enc->forward(batch);
  EXPECT_TRUE(torch::allclose(both.states[0].slice(0, 0, 5), alone.states[0],
                              1e-6, 1e-7));
  EXPECT_TRUE(torch::allclose(both.last[0], alone.last[0], 1e-6, 1e-7));
}

TEST(InstructionEncoderTest, TextFeaturesFeedTheLstmWithoutEmbedding) {
  // VLN-CE's RxR encoder: the [B, L, 768] features enter the (Bi)LSTM as
  // they are; zero rows at the end are padding
  torch::manual_seed(2);
  ModelConfig c = test::tinyConfig(PolicyType::kCma);
  c.instruction_features = InstructionFeatures::kRxrText;
  c.text_feature_dim = 8;
  InstructionEncoder enc(c);
  EXPECT_TRUE(enc->embedding.is_empty());
  EXPECT_EQ(enc->lstm->options.input_size(), 8);
  EXPECT_TRUE(enc->lstm->options.bidirectional());
  for (const auto& item : enc->named_parameters())
    EXPECT_EQ(item.key().rfind("lstm.", 0), 0u) << item.key();

  const torch::Tensor features = test::randomTextFeatures({4, 2, 6}, 8, 8);
  const auto out = enc->forward(features);
  EXPECT_EQ(out.states.sizes(), (std::vector<int64_t>{3, 6, 10}));
  EXPECT_TRUE(torch::equal(enc->featureLengths(features),
                           torch::tensor({4, 2, 6}, torch::kInt64)));
  // a row alone, unpadded, gives the same states
  const auto alone = enc->forward(features.slice(0, 1, 2).slice(1, 0, 2));
  EXPECT_TRUE(torch::allclose(out.states[1].slice(0, 0, 2), alone.states[0],
                              1e-6, 1e-7));
  EXPECT_EQ(out.states[1].slice(0, 2).abs().sum().item<float>(), 0.0f);
  // an all-zero row inside the text is input, not padding: the length
  // runs to the last non-zero row
  torch::Tensor gap = features.clone();
  gap[2][3].zero_();
  EXPECT_EQ(enc->featureLengths(gap)[2].item<int64_t>(), 6);
}

TEST(InstructionEncoderTest, BadTextFeaturesAreRejectedWithTheReason) {
  ModelConfig c = test::tinyConfig(PolicyType::kSeq2Seq);
  c.instruction_features = InstructionFeatures::kRxrText;
  c.text_feature_dim = 8;
  InstructionEncoder enc(c);
  EXPECT_THAT(errorOf([&] {
                enc->forward(torch::ones({2, 3, 7}));
              }),
              HasSubstr("expected float text features [B, L, 8] "
                        "(model.text_feature_dim), got [2, 3, 7]"));
  EXPECT_THAT(errorOf([&] {
                enc->forward(torch::ones({2, 3}, torch::kLong));
              }),
              HasSubstr("model.instruction_features is rxr_text"));
  torch::Tensor empty = torch::ones({2, 3, 8});
  empty[1].zero_();
  EXPECT_THAT(errorOf([&] { enc->forward(empty); }),
              HasSubstr("the text features of row 1 are all zero"));
  EXPECT_THAT(errorOf([&] {
                enc->setWordEmbeddings(torch::zeros({23, 6}));
              }),
              HasSubstr("has no word embedding"));
}

TEST(InstructionEncoderTest, BadTokensAreRejectedWithTheReason) {
  InstructionEncoder enc(tinyConfig(PolicyType::kCma));
  EXPECT_THAT(errorOf([&] {
                enc->forward(torch::tensor({{3, 0, 4}}, torch::kInt64));
              }),
              HasSubstr("found a PAD before a real token"));
  EXPECT_THAT(errorOf([&] {
                enc->forward(torch::tensor({{3, 23}}, torch::kInt64));
              }),
              HasSubstr("token id 23 is outside the vocabulary [0, 23)"));
  EXPECT_THAT(errorOf([&] {
                enc->forward(torch::tensor({{3, 1}, {0, 0}}, torch::kInt64));
              }),
              HasSubstr("an instruction has no tokens (row 1)"));
  EXPECT_THAT(errorOf([&] {
                enc->forward(torch::ones({2, 3}));
              }),
              HasSubstr("expected int64 tokens [B, L]"));
}

TEST(InstructionEncoderTest, WordEmbeddingsLoadAndFreeze) {
  ModelConfig c = tinyConfig(PolicyType::kSeq2Seq);
  InstructionEncoder frozen(c);
  EXPECT_FALSE(frozen->embedding->weight.requires_grad());
  torch::Tensor glove = torch::randn({23, 6});
  glove[0].zero_();
  frozen->setWordEmbeddings(glove);
  EXPECT_TRUE(torch::equal(frozen->embedding->weight, glove));
  EXPECT_THAT(errorOf([&] {
                frozen->setWordEmbeddings(torch::zeros({23, 5}));
              }),
              HasSubstr("expected a [23, 6] matrix"));
  c.fine_tune_embeddings = true;
  InstructionEncoder tuned(c);
  EXPECT_TRUE(tuned->embedding->weight.requires_grad());
}

TEST(InstructionEncoderTest, RandomWordEmbeddingsAreSeededAndSpareTheGlobalRng) {
  torch::manual_seed(7);
  const torch::Tensor expectedNext = torch::rand({4});
  torch::manual_seed(7);
  const torch::Tensor a = randomWordEmbeddings(23, 6, 11);
  // the draw has its own generator: the global stream is where it was
  EXPECT_TRUE(torch::equal(torch::rand({4}), expectedNext));
  EXPECT_EQ(a.sizes(), (std::vector<int64_t>{23, 6}));
  EXPECT_TRUE(torch::equal(a, randomWordEmbeddings(23, 6, 11)));
  EXPECT_FALSE(torch::equal(a, randomWordEmbeddings(23, 6, 12)));
  EXPECT_EQ(a[0].abs().sum().item<float>(), 0.0f);  // PAD
  // N(0, 1) rows: words start far apart, unlike a GloVe fitted on templates
  const torch::Tensor rows = a.slice(0, 1);
  EXPECT_NEAR(rows.mean().item<float>(), 0.0f, 0.3f);
  EXPECT_NEAR(rows.std().item<float>(), 1.0f, 0.2f);
  const torch::Tensor cosine = torch::cosine_similarity(
      rows.slice(0, 0, 11), rows.slice(0, 11, 22), /*dim=*/1);
  EXPECT_LT(cosine.abs().max().item<float>(), 0.99f);
  EXPECT_THAT(errorOf([] { randomWordEmbeddings(0, 6, 1); }),
              HasSubstr("vocab and dim must be >= 1"));
}

TEST(InstructionEncoderTest, RealGloveAndR2rTokensAtPaperSize) {
  const auto dir =
      vln::test::sharedFixturesPath() / "r2r_vlnce_v1-3_preprocessed";
  if (!std::filesystem::exists(dir / "embeddings.json.gz") ||
      !std::filesystem::exists(dir / "val_seen_sample.json.gz"))
    GTEST_SKIP() << "R2R_VLNCE fixtures absent";
  // embeddings.json.gz: [vocab][50] floats, PAD row 0 all zeros
  const auto glove = common::readJsonFile(dir / "embeddings.json.gz");
  std::vector<float> values;
  for (const auto& row : glove)
    for (const auto& x : row) values.push_back(x.get<float>());
  const int64_t vocab = static_cast<int64_t>(glove.size());
  const torch::Tensor matrix =
      torch::from_blob(values.data(), {vocab, 50}).clone();
  ModelConfig c;  // paper sizes: the file must fit them
  ASSERT_EQ(vocab, c.vocab_size);
  InstructionEncoder enc(c);
  enc->setWordEmbeddings(matrix);

  // episodes store tokens padded with PAD to 200
  const auto data = common::readJsonFile(dir / "val_seen_sample.json.gz");
  std::vector<int64_t> ids;
  for (const auto& t :
       data.at("episodes").at(0).at("instruction").at("instruction_tokens"))
    ids.push_back(t.get<int64_t>());
  const torch::Tensor padded =
      torch::tensor(ids, torch::kInt64).unsqueeze(0);  // [1, 200]
  const int64_t len = enc->lengths(padded)[0].item<int64_t>();
  ASSERT_GT(len, 0);
  ASSERT_LT(len, padded.size(1));
  torch::NoGradGuard g;
  const auto full = enc->forward(padded);
  const auto trimmed = enc->forward(padded.slice(1, 0, len));
  EXPECT_EQ(full.states.size(1), len);
  EXPECT_TRUE(torch::allclose(full.states, trimmed.states, 1e-6, 1e-7));
  EXPECT_EQ(full.states.size(2), 2 * c.instruction_hidden_size);
}

}  // namespace
}  // namespace vln::models
