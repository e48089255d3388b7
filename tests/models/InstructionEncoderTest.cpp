#include "models/InstructionEncoder.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "ModelTestUtil.h"

namespace vln::models {
namespace {

using test::randomTokens;
using test::tinyConfig;
using ::testing::HasSubstr;

std::string errorOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const std::exception& e) {
    return e.what();
  }
  return "";
}

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
  EXPECT_THAT(errorOf([&] { enc->forward(torch::ones({2, 3})); }),
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
  EXPECT_THAT(errorOf([&] { frozen->setWordEmbeddings(torch::zeros({23, 5})); }),
              HasSubstr("expected a [23, 6] matrix"));
  c.fine_tune_embeddings = true;
  InstructionEncoder tuned(c);
  EXPECT_TRUE(tuned->embedding->weight.requires_grad());
}

}  // namespace
}  // namespace vln::models
