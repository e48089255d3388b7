#include "models/MaskedGru.h"

#include <gtest/gtest.h>

namespace vln::models {
namespace {

TEST(MaskedGruTest, ChunkedRunEqualsCellLoopWithResets) {
  torch::manual_seed(4);
  MaskedGru gru(6, 5);
  gru->to(torch::kDouble);
  const int64_t steps = 9, batch = 3;
  const torch::Tensor x = torch::randn({steps, batch, 6}, torch::kDouble);
  const torch::Tensor h0 = torch::randn({batch, 5}, torch::kDouble);
  torch::Tensor notDone = torch::ones({steps, batch}, torch::kDouble);
  notDone[0][1] = 0;
  notDone[4][0] = 0;
  notDone[4][2] = 0;
  notDone[7][2] = 0;
  const auto [out, last] = gru->forward(x, h0, notDone);

  const auto w = gru->gru->all_weights();
  torch::Tensor h = h0;
  for (int64_t t = 0; t < steps; ++t) {
    h = torch::gru_cell(x[t], h * notDone[t].unsqueeze(1), w[0], w[1], w[2],
                        w[3]);
    EXPECT_TRUE(torch::allclose(out[t], h, 1e-12, 1e-12)) << "t=" << t;
  }
  EXPECT_TRUE(torch::allclose(last, h, 1e-12, 1e-12));
}

TEST(MaskedGruTest, GradientsEqualAutogradThroughCellLoop) {
  torch::manual_seed(5);
  MaskedGru gru(4, 6);
  gru->to(torch::kDouble);
  const int64_t steps = 7, batch = 3;
  const torch::Tensor x =
      torch::randn({steps, batch, 4}, torch::kDouble).requires_grad_();
  const torch::Tensor h0 =
      torch::randn({batch, 6}, torch::kDouble).requires_grad_();
  torch::Tensor notDone = torch::ones({steps, batch}, torch::kDouble);
  notDone[3][1] = 0;
  notDone[5][0] = 0;
  const torch::Tensor probe = torch::randn({steps, batch, 6}, torch::kDouble);
  const torch::Tensor probeLast = torch::randn({batch, 6}, torch::kDouble);

  const auto [out, last] = gru->forward(x, h0, notDone);
  const auto params = gru->parameters();
  std::vector<torch::Tensor> wrt{x, h0};
  wrt.insert(wrt.end(), params.begin(), params.end());
  const auto fast = torch::autograd::grad(
      {(out * probe).sum() + (last * probeLast).sum()}, wrt);

  const auto w = gru->gru->all_weights();
  torch::Tensor h = h0;
  std::vector<torch::Tensor> outs;
  for (int64_t t = 0; t < steps; ++t) {
    h = torch::gru_cell(x[t], h * notDone[t].unsqueeze(1), w[0], w[1], w[2],
                        w[3]);
    outs.push_back(h);
  }
  const auto reference = torch::autograd::grad(
      {(torch::stack(outs) * probe).sum() + (h * probeLast).sum()}, wrt);
  ASSERT_EQ(fast.size(), reference.size());
  for (size_t i = 0; i < fast.size(); ++i)
    EXPECT_TRUE(torch::allclose(fast[i], reference[i], 1e-10, 1e-12))
        << "gradient " << i;
}

TEST(MaskedGruTest, InitIsOrthogonalWithZeroBias) {
  MaskedGru gru(8, 4);
  const auto w = gru->gru->all_weights();
  // weight_ih [12, 8]: orthonormal columns
  EXPECT_TRUE(torch::allclose(w[0].t().mm(w[0]), torch::eye(8), 1e-5, 1e-5));
  EXPECT_EQ(w[2].abs().sum().item<float>(), 0.0f);
  EXPECT_EQ(w[3].abs().sum().item<float>(), 0.0f);
}

TEST(MaskedGruTest, WrongShapesAreNamed) {
  MaskedGru gru(3, 2);
  EXPECT_THROW(gru->forward(torch::zeros({4, 2, 3}), torch::zeros({3, 2}),
                            torch::ones({4, 2})),
               c10::Error);
  EXPECT_THROW(gru->forward(torch::zeros({4, 2, 3}), torch::zeros({2, 2}),
                            torch::ones({3, 2})),
               c10::Error);
}

}  // namespace
}  // namespace vln::models
