#include "models/Loss.h"

#include <torch/torch.h>

#include <gtest/gtest.h>

#include <cmath>

namespace vln::models {
namespace {

TEST(LossTest, InflectionWeightsMarkChangesAndPadding) {
  // columns: [F F L L STOP], [F L F pad pad]
  const torch::Tensor actions =
      torch::tensor({1, 1, 1, 2, 2, 1, 2, 0, 0, 0}, torch::kInt64).view({5, 2});
  const torch::Tensor valid =
      torch::tensor({1, 1, 1, 1, 1, 1, 1, 0, 1, 0}, torch::kBool).view({5, 2});
  const torch::Tensor w = inflectionWeights(actions, valid, 3.2);
  const torch::Tensor expected = torch::tensor({3.2f, 3.2f, 1.0f, 3.2f, 3.2f,
                                                3.2f, 1.0f, 0.0f, 3.2f, 0.0f})
                                     .view({5, 2});
  EXPECT_TRUE(torch::allclose(w, expected));
}

TEST(LossTest, WeightedActionLossAveragesPerEpisodeThenOverBatch) {
  torch::manual_seed(0);
  const torch::Tensor logits = torch::randn({3, 2, 4});
  const torch::Tensor actions =
      torch::tensor({0, 1, 2, 3, 1, 9}, torch::kInt64).view({3, 2});
  // the last step of episode 1 is padding holding an invalid id
  const torch::Tensor weights =
      torch::tensor({3.2f, 3.2f, 1.0f, 3.2f, 3.2f, 0.0f}).view({3, 2});
  const torch::Tensor loss = weightedActionLoss(logits, actions, weights);

  const torch::Tensor logp = torch::log_softmax(logits, -1);
  double total = 0.0;
  for (int64_t b = 0; b < 2; ++b) {
    double num = 0.0, den = 0.0;
    for (int64_t t = 0; t < 3; ++t) {
      const double wt = weights[t][b].item<double>();
      if (wt == 0.0) continue;
      num += -wt * logp[t][b][actions[t][b].item<int64_t>()].item<double>();
      den += wt;
    }
    total += num / den;
  }
  EXPECT_NEAR(loss.item<double>(), total / 2.0, 1e-6);
}

TEST(LossTest, ProgressLossIgnoresPaddedSteps) {
  const torch::Tensor progress = torch::tensor({0.5f, 0.0f, 1.0f, 0.9f});
  const torch::Tensor target = torch::tensor({0.25f, 7.0f, 1.0f, 0.5f});
  const torch::Tensor valid = torch::tensor({true, false, true, true});
  const double expected = (0.0625 + 0.0 + 0.16) / 3.0;
  EXPECT_NEAR(progressLoss(progress.view({2, 2}), target.view({2, 2}),
                           valid.view({2, 2}))
                  .item<double>(),
              expected, 1e-7);
}

}  // namespace
}  // namespace vln::models

namespace vln::models {
namespace {

// softplus(log p_swapped(label) - log p_own(label)) by hand: equal logits
// give ln 2; own p = 0.8 and swapped p = 0.2 give ln(1 + 0.2 / 0.8); invalid
// entries count for nothing, whatever their label
TEST(LossTest, InstructionContrastByHand) {
  const torch::Tensor own =
      torch::log(torch::tensor({0.8f, 0.2f, 0.5f, 0.5f, 0.1f, 0.9f}))
          .view({3, 2});
  const torch::Tensor swapped =
      torch::log(torch::tensor({0.2f, 0.8f, 0.5f, 0.5f, 0.9f, 0.1f}))
          .view({3, 2});
  const torch::Tensor labels = torch::tensor({0, 1, 7}, torch::kInt64);
  const torch::Tensor valid = torch::tensor({1, 1, 0}, torch::kBool);
  const double expected = (std::log(1.0 + 0.2 / 0.8) + std::log(2.0)) / 2.0;
  EXPECT_NEAR(instructionContrast(own, swapped, labels, valid).item<double>(),
              expected, 1e-6);
  EXPECT_NEAR(instructionContrast(own, own, labels, valid).item<double>(),
              std::log(2.0), 1e-6);
  // the [T, B] layout of the low-level trainer reduces the same way
  EXPECT_NEAR(instructionContrast(own.view({3, 1, 2}), swapped.view({3, 1, 2}),
                                  labels.view({3, 1}), valid.view({3, 1}))
                  .item<double>(),
              expected, 1e-6);
  EXPECT_THROW(instructionContrast(own, swapped.view({2, 3}), labels, valid),
               c10::Error);
}

}  // namespace
}  // namespace vln::models
