// WaypointDecisionModel: an ensemble's logits are the log of its members'
// averaged choice probabilities (masked slots stay -inf), a NativeWaypointModel
// over several policies steps each with its own recurrent state and returns
// exactly that average, one policy keeps its raw logits, and members that
// read other inputs are refused.

#include "rollout/WaypointDecisionModel.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <limits>

#include "rollout/RolloutTestPolicy.h"
#include "rollout/RolloutTestWorld.h"

namespace vln::rollout {
namespace {

using ::testing::HasSubstr;

constexpr double kInf = std::numeric_limits<double>::infinity();

int64_t flat(const models::FeatureShape& s) { return s[0] * s[1] * s[2]; }

std::shared_ptr<models::WaypointCmaPolicyImpl> tinyPolicy(
    uint64_t seed, int64_t views, const models::ModelConfig& model) {
  torch::manual_seed(seed);
  return std::make_shared<models::WaypointCmaPolicyImpl>(
      model, views, flat(models::rgbFeatureShape(model)),
      flat(models::depthFeatureShape(model)));
}

TEST(EnsembleLogitsTest, AveragesTheMembersProbabilities) {
  const torch::Tensor a =
      torch::tensor({{0.0, 1.0, -kInf}, {2.0, -1.0, 0.5}}, torch::kFloat64);
  const torch::Tensor b =
      torch::tensor({{3.0, -2.0, -kInf}, {0.0, 0.0, 0.0}}, torch::kFloat64);
  const torch::Tensor both[] = {a, b};
  const torch::Tensor out = ensembleLogits(both);
  const torch::Tensor expected =
      torch::log((torch::softmax(a, -1) + torch::softmax(b, -1)) / 2.0);
  ASSERT_EQ(out.sizes(), a.sizes());
  EXPECT_EQ(out[0][2].item<double>(), -kInf);  // masked by every member
  EXPECT_TRUE(torch::allclose(out.nan_to_num(0, 0, 0),
                              expected.nan_to_num(0, 0, 0), 1e-12, 1e-12));
  // the rows are log-probabilities: they sum to one
  EXPECT_TRUE(torch::allclose(torch::exp(out).sum(-1),
                              torch::ones({2}, torch::kFloat64)));
  // in row 0 member a prefers slot 1 (0.73) and b slot 0 (0.99): the average
  // follows b's confident choice
  EXPECT_GT(out[0][0].item<double>(), out[0][1].item<double>());

  // one member: its log-softmax
  const torch::Tensor one[] = {a};
  EXPECT_TRUE(torch::allclose(ensembleLogits(one).nan_to_num(0, 0, 0),
                              torch::log_softmax(a, -1).nan_to_num(0, 0, 0)));
  // members that disagree on the slots, or none, are refused
  const torch::Tensor mismatched[] = {a, torch::zeros({2, 4}, torch::kFloat64)};
  EXPECT_THROW(ensembleLogits(mismatched), std::invalid_argument);
  EXPECT_THROW(ensembleLogits({}), std::invalid_argument);
}

// two decisions of three environments through `model`, on fixed inputs
std::vector<torch::Tensor> twoDecisions(WaypointDecisionModel& model) {
  const auto& w = test::rolloutTestWorld();
  for (int env = 0; env < 3; ++env)
    model.reset(env, w.episodes[static_cast<size_t>(env)]);
  torch::manual_seed(11);
  const torch::Tensor rgb =
      torch::randint(0, 256, {3, 12, 32, 32, 3}, torch::kUInt8);
  const torch::Tensor depth = torch::rand({3, 12, 32, 32, 1});
  const PanoramaFeatures features = model.encode(rgb, depth);
  const torch::Tensor candidates = torch::stack(
      {torch::rand({3, 4}) * 6.28, torch::rand({3, 4}) * 2.75 + 0.25}, -1);
  const torch::Tensor mask =
      torch::tensor({1, 1, 0, 0, 1, 1, 1, 1, 0, 0, 0, 0}, torch::kBool)
          .view({3, 4});
  const torch::Tensor prev = torch::zeros({3, 2});
  const torch::Tensor notDone = torch::ones({3});
  const int envs[] = {0, 1, 2};
  std::vector<torch::Tensor> out;
  for (int step = 0; step < 2; ++step)
    out.push_back(model.step(envs, features, candidates, mask, prev, notDone,
                             at::Tensor()));
  return out;
}

TEST(NativeWaypointModelTest, AnEnsembleAveragesItsPoliciesStepByStep) {
  const models::ModelConfig config = test::tinyModel(models::PolicyType::kCma);
  const auto a = tinyPolicy(1, 12, config);
  const auto b = tinyPolicy(2, 12, config);
  torch::manual_seed(0);
  const models::ObservationEncoder encoder(config);
  auto native = [&](std::vector<std::shared_ptr<models::WaypointCmaPolicyImpl>>
                        policies) {
    return NativeWaypointModel(std::move(policies), encoder,
                               models::WaypointPredictor{nullptr},
                               CandidateNms{}, 200);
  };
  NativeWaypointModel onlyA = native({a});
  NativeWaypointModel onlyB = native({b});
  NativeWaypointModel ensemble = native({a, b});
  const std::vector<torch::Tensor> x = twoDecisions(onlyA);
  const std::vector<torch::Tensor> y = twoDecisions(onlyB);
  const std::vector<torch::Tensor> z = twoDecisions(ensemble);
  ASSERT_EQ(z.size(), 2u);
  for (size_t step = 0; step < z.size(); ++step) {
    SCOPED_TRACE(step);
    // STOP and the two candidates of env 0; STOP alone in env 2
    EXPECT_EQ(z[step].sizes(), (std::vector<int64_t>{3, 5}));
    const torch::Tensor members[] = {x[step], y[step]};
    const torch::Tensor expected = ensembleLogits(members);
    EXPECT_TRUE(
        torch::equal(torch::isfinite(z[step]), torch::isfinite(expected)));
    EXPECT_TRUE(torch::allclose(z[step].nan_to_num(0, 0, 0),
                                expected.nan_to_num(0, 0, 0), 1e-9, 1e-9));
    EXPECT_DOUBLE_EQ(z[step][2][0].item<double>(), 0.0);  // log 1: only STOP
  }
  // the members' states advance: the second decision differs from the first
  EXPECT_FALSE(
      torch::allclose(z[0].nan_to_num(0, 0, 0), z[1].nan_to_num(0, 0, 0)));
  // one policy: its raw logits, not renormalised
  EXPECT_FALSE(torch::allclose(torch::exp(x[0]).sum(-1),
                               torch::ones({3}, torch::kFloat64)));
}

TEST(NativeWaypointModelTest, RefusesMembersThatReadOtherInputs) {
  const models::ModelConfig config = test::tinyModel(models::PolicyType::kCma);
  const models::ObservationEncoder encoder(config);
  try {
    NativeWaypointModel model(
        {tinyPolicy(1, 12, config), tinyPolicy(2, 8, config)}, encoder,
        models::WaypointPredictor{nullptr}, CandidateNms{}, 200);
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("ensemble member 1 reads 8 views"));
  }
  EXPECT_THROW(
      NativeWaypointModel(
          std::vector<std::shared_ptr<models::WaypointCmaPolicyImpl>>{},
          encoder, models::WaypointPredictor{nullptr}, CandidateNms{}, 200),
      std::invalid_argument);
}

}  // namespace
}  // namespace vln::rollout
