// Tests src/models/WaypointPredictor.cpp: the heatmap layout of the views'
// outputs (bin 10k on view k's axis), the output shape, exact rotation
// equivariance (rolling the views by one rolls the logits by one view's
// bins), the losses on hand cases and the softmax over the cells.

#include "models/WaypointPredictor.h"

#include <gtest/gtest.h>

#include <cmath>

namespace vln::models {
namespace {

TEST(WaypointPredictorTest, ViewOutputsAreCentredOnTheirViewsAxis) {
  // 12 views of 10 bins: view k's middle output (j = 5) is bin 10k, its
  // first (j = 0) bin 10k - 5, wrapping below 0
  for (int k : {0, 1, 6, 11}) {
    for (int j : {0, 5, 9}) {
      torch::Tensor perView = torch::zeros({1, 12, 10 * 12});
      perView[0][k][j * 12 + 3] = 1.0f;
      const torch::Tensor heatmap = viewOutputsToHeatmap(perView);
      ASSERT_EQ(heatmap.sizes(), (std::vector<int64_t>{1, 120, 12}));
      const int expected = ((10 * k - 5 + j) % 120 + 120) % 120;
      EXPECT_EQ(heatmap[0][expected][3].item<float>(), 1.0f)
          << "view " << k << " output " << j;
      EXPECT_EQ(heatmap.sum().item<float>(), 1.0f);
    }
  }
  // 4 views of 30 bins: view 1's axis is bin 30
  torch::Tensor four = torch::zeros({1, 4, 30 * 12});
  four[0][1][15 * 12] = 1.0f;
  EXPECT_EQ(viewOutputsToHeatmap(four)[0][30][0].item<float>(), 1.0f);
  EXPECT_THROW(viewOutputsToHeatmap(torch::zeros({1, 7, 12})), c10::Error);
}

TEST(WaypointPredictorTest, OutputsOneHeatmapPerPanorama) {
  torch::manual_seed(0);
  WaypointPredictor net(WaypointPredictorConfig{}, 12, 512, 64);
  const torch::Tensor logits =
      net->forward(torch::rand({3, 12, 512}), torch::rand({3, 12, 64}));
  EXPECT_EQ(logits.sizes(), (std::vector<int64_t>{3, 120, 12}));
  EXPECT_TRUE(torch::isfinite(logits).all().item<bool>());
  // a modality the network was built with is required
  EXPECT_THROW(net->forward(torch::rand({3, 12, 512}), torch::Tensor()),
               c10::Error);
  WaypointPredictor depthOnly(WaypointPredictorConfig{}, 12, 512, 0);
  EXPECT_EQ(
      depthOnly->forward(torch::rand({2, 12, 512}), torch::Tensor()).sizes(),
      (std::vector<int64_t>{2, 120, 12}));
  EXPECT_THROW(WaypointPredictor(WaypointPredictorConfig{}, 7, 512, 0),
               std::invalid_argument);
  EXPECT_THROW(WaypointPredictor(WaypointPredictorConfig{}, 12, 0, 0),
               std::invalid_argument);
  WaypointPredictorConfig odd;
  odd.heads = 3;
  EXPECT_THROW(WaypointPredictor(odd, 12, 512, 0), std::invalid_argument);
}

TEST(WaypointPredictorTest, TurningByOneViewRollsTheLogitsByTenBins) {
  for (int neighbors : {1, -1}) {
    torch::manual_seed(1);
    WaypointPredictorConfig config;
    config.neighbors = neighbors;
    WaypointPredictor net(config, 12, 40, 24);
    net->eval();  // no dropout
    // the offset biases start at zero; make them matter
    for (const auto& layer : *net->layers) {
      torch::NoGradGuard guard;
      layer->as<ViewAttentionLayer>()->offset_bias.normal_();
    }
    const torch::Tensor depth = torch::randn({2, 12, 40});
    const torch::Tensor rgb = torch::randn({2, 12, 24});
    const torch::Tensor logits = net->forward(depth, rgb);
    // the agent turned one view to the right: its view k is the old view
    // k - 1, and what was at bin h is now at bin h + 10
    const torch::Tensor turned =
        net->forward(torch::roll(depth, {1}, {1}), torch::roll(rgb, {1}, {1}));
    EXPECT_TRUE(
        torch::allclose(turned, torch::roll(logits, {10}, {1}), 1e-4, 1e-5))
        << "neighbors " << neighbors;
    // and it is not trivially constant across headings
    EXPECT_GT(
        (logits - torch::roll(logits, {10}, {1})).abs().max().item<float>(),
        1e-3);
  }
}

TEST(WaypointPredictorTest, NeighbourMaskLimitsWhatAViewSees) {
  // one layer attending to one neighbour per side: view 6's tokens and so
  // its bins (55..64) cannot depend on view 0
  torch::manual_seed(2);
  WaypointPredictorConfig config;
  config.layers = 1;
  config.neighbors = 1;
  WaypointPredictor net(config, 12, 16, 0);
  net->eval();
  torch::Tensor depth = torch::randn({1, 12, 16});
  const torch::Tensor before = net->forward(depth, torch::Tensor());
  depth[0][0] += 5.0f;
  const torch::Tensor after = net->forward(depth, torch::Tensor());
  const auto slice = torch::indexing::Slice(55, 65);
  EXPECT_TRUE(torch::equal(before.index({0, slice}), after.index({0, slice})));
  // its own bins and its neighbours' do
  EXPECT_FALSE(torch::equal(before.index({0, torch::indexing::Slice(5, 15)}),
                            after.index({0, torch::indexing::Slice(5, 15)})));
}

TEST(WaypointPredictorTest, LossesOnHandCases) {
  torch::Tensor target = torch::zeros({1, 120, 12});
  target[0][30][4] = 1.0f;
  const torch::Tensor zeros = torch::zeros({1, 120, 12});
  // squared error against the scaled target: 10^2 in one cell, / 120
  EXPECT_NEAR(
      waypointLoss(zeros, target, WaypointLoss::kMse, 10.0).item<double>(),
      100.0 / 120.0, 1e-6);
  torch::Tensor exact = target * 10.0f;
  EXPECT_NEAR(
      waypointLoss(exact, target, WaypointLoss::kMse, 10.0).item<double>(), 0.0,
      1e-9);
  // averaged over the batch
  EXPECT_NEAR(
      waypointLoss(torch::cat({zeros, exact}), torch::cat({target, target}),
                   WaypointLoss::kMse, 10.0)
          .item<double>(),
      50.0 / 120.0, 1e-6);
  // softmax: uniform logits cost log(1440) whatever the target's scale
  EXPECT_NEAR(waypointLoss(zeros, target * 0.3f, WaypointLoss::kSoftmax, 10.0)
                  .item<double>(),
              std::log(1440.0), 1e-5);
  // two target cells of mass 1 and 3 against logits favouring the first:
  // -(0.25 log p1 + 0.75 log p2)
  torch::Tensor two = target.clone();
  two[0][90][0] = 3.0f;
  torch::Tensor logits = torch::zeros({1, 120, 12});
  logits[0][30][4] = 2.0f;
  const double z = 1439.0 + std::exp(2.0);
  EXPECT_NEAR(
      waypointLoss(logits, two, WaypointLoss::kSoftmax, 1.0).item<double>(),
      -(0.25 * (2.0 - std::log(z)) + 0.75 * (0.0 - std::log(z))), 1e-5);
  EXPECT_THROW(
      waypointLoss(torch::zeros({1, 120, 11}), torch::zeros({1, 120, 11}),
                   WaypointLoss::kMse, 1.0),
      c10::Error);
}

TEST(WaypointPredictorTest, ProbabilitiesAreASoftmaxOverAllCells) {
  torch::Tensor logits = torch::zeros({2, 120, 12});
  logits[1][7][2] = std::log(1439.0f);  // as much as the 1439 others
  const torch::Tensor p = waypointProbabilities(logits);
  EXPECT_EQ(p.sizes(), logits.sizes());
  EXPECT_NEAR(p[0].sum().item<float>(), 1.0f, 1e-5);
  EXPECT_NEAR(p[0][3][3].item<float>(), 1.0f / 1440.0f, 1e-8);
  EXPECT_NEAR(p[1][7][2].item<float>(), 0.5f, 1e-5);
}

}  // namespace
}  // namespace vln::models
