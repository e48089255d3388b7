// PointNavPolicy: a padded batch of episodes of different lengths computes
// what each episode computes alone, and the blind control has no depth
// input at all.

#include "models/PointNavPolicy.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <vector>

namespace vln::models {
namespace {

using ::testing::HasSubstr;

// a small CNN on 32x32 depth, as the pretraining tests use
ModelConfig tinyDepthModel() {
  ModelConfig model;
  model.depth_encoder = EncoderType::kSmallCnn;
  model.depth_width = model.depth_height = 32;
  model.depth_projection_size = 32;
  return model;
}

PointNavInputs randomInputs(int64_t steps, const std::vector<int64_t>& lengths,
                            int64_t size) {
  const int64_t batch = static_cast<int64_t>(lengths.size());
  PointNavInputs in;
  std::vector<int64_t> index;
  for (int64_t b = 0; b < batch; ++b)
    for (int64_t t = 0; t < lengths[static_cast<size_t>(b)]; ++t)
      index.push_back(t * batch + b);
  in.frame_index = torch::tensor(index, torch::kLong);
  in.depth = torch::rand({static_cast<int64_t>(index.size()), size, size, 1});
  in.goal = torch::randn({steps, batch, 3});
  in.prev_actions = torch::randint(0, 4, {steps, batch}, torch::kLong);
  in.not_done = torch::ones({steps, batch});
  in.not_done[0].zero_();
  return in;
}

TEST(PointNavPolicyTest, PaddedBatchEqualsEpisodesRunAlone) {
  const ModelConfig model = tinyDepthModel();
  torch::manual_seed(3);
  PointNavPolicy policy(model, /*hiddenSize=*/16, /*useDepth=*/true);
  const std::vector<int64_t> lengths = {5, 2, 4};
  const PointNavInputs in = randomInputs(5, lengths, 32);
  auto [logits, last] = policy->forward(in, policy->initialHidden(3));
  ASSERT_EQ(logits.sizes(), (std::vector<int64_t>{5, 3, 4}));
  ASSERT_EQ(last.sizes(), (std::vector<int64_t>{3, 16}));

  // episode 1 alone: its frames, goals and actions at T = 2, B = 1
  PointNavInputs alone;
  const torch::Tensor frames =
      torch::tensor(std::vector<int64_t>{5, 6});  // after episode 0's five
  alone.depth = in.depth.index_select(0, frames);
  alone.frame_index = torch::arange(2, torch::kLong);
  alone.goal = in.goal.slice(0, 0, 2).slice(1, 1, 2);
  alone.prev_actions = in.prev_actions.slice(0, 0, 2).slice(1, 1, 2);
  alone.not_done = in.not_done.slice(0, 0, 2).slice(1, 1, 2);
  auto [aloneLogits, aloneLast] =
      policy->forward(alone, policy->initialHidden(1));
  EXPECT_TRUE(torch::allclose(aloneLogits.squeeze(1),
                              logits.slice(0, 0, 2).select(1, 1), 1e-5, 1e-6));
}

TEST(PointNavPolicyTest, BlindControlHasNoDepthInput) {
  const ModelConfig model = tinyDepthModel();
  PointNavPolicy blind(model, 16, /*useDepth=*/false);
  PointNavPolicy seeing(model, 16, /*useDepth=*/true);
  EXPECT_FALSE(blind->usesDepth());
  EXPECT_TRUE(seeing->usesDepth());
  for (const auto& item : blind->named_parameters())
    EXPECT_THAT(item.key(), ::testing::Not(HasSubstr("depth"))) << item.key();
  PointNavInputs in = randomInputs(3, {3, 3}, 32);
  in.depth = torch::Tensor();
  in.frame_index = torch::Tensor();
  auto [logits, last] = blind->forward(in, blind->initialHidden(2));
  EXPECT_EQ(logits.sizes(), (std::vector<int64_t>{3, 2, 4}));
  EXPECT_THROW(seeing->forward(in, seeing->initialHidden(2)), c10::Error);
}

}  // namespace
}  // namespace vln::models
