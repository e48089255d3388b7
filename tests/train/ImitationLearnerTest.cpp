// Tests of src/train/ImitationLearner.cpp: the inverse inflection frequency
// on hand-made ground truth, non-finite losses skipped (nothing changes),
// the consecutive-fault limit, learning on a small synthetic store, and
// gradient accumulation equal to one update on the concatenated batch.

#include "train/ImitationLearner.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>

#include "common/Config.h"
#include "models/StateDict.h"
#include "support/TestPaths.h"
#include "train/LearnerTestUtil.h"

namespace vln::train {
namespace {

using ::testing::HasSubstr;
using test::layoutOf;
using test::tinyLearnerConfig;

// episodes whose oracle action is readable from the features: the depth
// map's channel `a` is bright where the label is a
void fillStore(FeatureStore& store, const ExperimentConfig& c, int episodes) {
  const auto r = models::rgbFeatureShape(c.model);
  const auto d = models::depthFeatureShape(c.model);
  torch::manual_seed(5);
  for (int i = 0; i < episodes; ++i) {
    StoredEpisode e;
    e.key.episode_id = i;
    e.key.slot = i;
    const int T = 4 + i % 5;
    e.tokens = {1 + i % 10, 2, 3};
    e.rgb = torch::rand({T, r[0], r[1], r[2]}) * 0.1;
    e.depth = torch::rand({T, d[0], d[1], d[2]}) * 0.1;
    test::setMadeUpActions(e, i, T);
    for (int t = 0; t < T; ++t)
      e.depth[t][e.oracle_actions[static_cast<size_t>(t)]].fill_(1.0);
    store.append(e);
  }
}

TEST(ImitationLearnerTest, InverseInflectionFrequencyOfHandMadeGroundTruth) {
  using sim::Action;
  data::GroundTruth a, b;
  // inflections at t = 0, 3 (2 after 1) and 4 (0 after 2): 3 of 5 actions
  a[1].actions = {Action::kMoveForward, Action::kMoveForward,
                  Action::kMoveForward, Action::kTurnLeft, Action::kStop};
  // t = 0 and t = 2: 2 of 3
  b[7].actions = {Action::kTurnRight, Action::kTurnRight, Action::kStop};
  EXPECT_DOUBLE_EQ(inverseInflectionFrequency({&a}), 5.0 / 3.0);
  EXPECT_DOUBLE_EQ(inverseInflectionFrequency({&a, &b, nullptr}), 8.0 / 5.0);
  data::GroundTruth empty;
  EXPECT_THAT([&] { inverseInflectionFrequency({&empty}); },
              ::testing::ThrowsMessage<std::invalid_argument>(
                  HasSubstr("inflection_weight")));
}

TEST(ImitationLearnerTest, NonFiniteLossSkipsTheUpdateAndIsCounted) {
  const ExperimentConfig c = tinyLearnerConfig(4);
  vln::test::TempDir dir;
  FeatureStore store(dir / "store", layoutOf(c), 0.05);
  fillStore(store, c, 8);
  torch::manual_seed(1);
  auto policy = models::makePolicy(c.model);
  ImitationLearner learner(policy, c);

  std::vector<torch::Tensor> before;
  for (const auto& p : policy->parameters())
    before.push_back(p.detach().clone());
  const std::vector<int64_t> indices = {0, 1, 2};
  learner.setLossHook(
      [](const torch::Tensor& loss) { return loss * std::nan(""); });
  UpdateResult skipped = learner.update(store.loadBatch(indices));
  EXPECT_TRUE(skipped.skipped);
  EXPECT_EQ(learner.updates(), 0);
  EXPECT_EQ(learner.nonFiniteInARow(), 1);
  const auto params = policy->parameters();
  for (size_t i = 0; i < params.size(); ++i)
    EXPECT_TRUE(torch::equal(params[i], before[i]));
  // Adam saw no step: its state is still empty
  EXPECT_TRUE(learner.optimizer().state().empty());

  // an infinite loss is skipped too; a finite one applies and resets the run
  learner.setLossHook(
      [](const torch::Tensor& loss) { return loss + INFINITY; });
  EXPECT_TRUE(learner.update(store.loadBatch(indices)).skipped);
  EXPECT_EQ(learner.nonFiniteInARow(), 2);
  learner.setLossHook({});
  UpdateResult applied = learner.update(store.loadBatch(indices));
  EXPECT_FALSE(applied.skipped);
  EXPECT_TRUE(std::isfinite(applied.loss));
  EXPECT_EQ(learner.updates(), 1);
  EXPECT_EQ(learner.nonFiniteInARow(), 0);
  EXPECT_EQ(learner.nonFiniteTotal(), 2);
  bool changed = false;
  for (size_t i = 0; i < params.size(); ++i)
    changed |= !torch::equal(params[i], before[i]);
  EXPECT_TRUE(changed);
}

TEST(ImitationLearnerTest, TooManyConsecutiveNonFiniteLossesStopTraining) {
  const ExperimentConfig c = tinyLearnerConfig(4);
  vln::test::TempDir dir;
  FeatureStore store(dir / "store", layoutOf(c), 0.05);
  fillStore(store, c, 16);  // 4 batches, limit 3
  auto policy = models::makePolicy(c.model);
  ImitationLearner learner(policy, c);
  learner.setLossHook(
      [](const torch::Tensor& loss) { return loss * std::nan(""); });
  int seen = 0;
  EXPECT_THAT(
      [&] {
        learner.trainEpoch(store, 1, 0, [&](const UpdateResult&) { ++seen; });
      },
      ::testing::ThrowsMessage<std::runtime_error>(
          HasSubstr("3 consecutive non-finite losses "
                    "(trainer.max_nonfinite_updates = 3)")));
  EXPECT_EQ(seen, 2);  // the third one throws before the callback
  EXPECT_EQ(learner.updates(), 0);
}

TEST(ImitationLearnerTest, IsolatedNonFiniteLossesDoNotStopAnEpoch) {
  const ExperimentConfig c = tinyLearnerConfig(4);
  vln::test::TempDir dir;
  FeatureStore store(dir / "store", layoutOf(c), 0.05);
  fillStore(store, c, 16);
  auto policy = models::makePolicy(c.model);
  ImitationLearner learner(policy, c);
  int calls = 0;
  learner.setLossHook([&](const torch::Tensor& loss) {
    return ++calls % 2 == 0 ? loss * std::nan("") : loss;
  });
  const EpochResult r = learner.trainEpoch(store, 1, 0);
  EXPECT_EQ(r.updates, 2);
  EXPECT_EQ(r.skipped, 2);
  EXPECT_TRUE(std::isfinite(r.mean.loss));
}

TEST(ImitationLearnerTest, LossFallsOnALearnableStore) {
  ExperimentConfig c = tinyLearnerConfig(4);
  vln::test::TempDir dir;
  FeatureStore store(dir / "store", layoutOf(c), 0.05);
  fillStore(store, c, 12);
  torch::manual_seed(3);
  auto policy = models::makePolicy(c.model);
  ImitationLearner learner(policy, c);
  const EpochResult first = learner.trainEpoch(store, 1, 0);
  EpochResult last;
  for (int epoch = 1; epoch < 30; ++epoch)
    last = learner.trainEpoch(store, 1, epoch);
  EXPECT_LT(last.mean.action_loss, 0.5 * first.mean.action_loss);
  EXPECT_LT(last.mean.progress_loss, first.mean.progress_loss);
  EXPECT_EQ(learner.updates(), 30 * 3);
}

TEST(ImitationLearnerTest, TextFeatureModelTrainsOnTheBatchsFeatures) {
  // model.instruction_features: rxr_text reads EpisodeBatch::text_features
  // (RxR's [B, L, 768] features, narrow here) instead of the tokens
  ExperimentConfig c = tinyLearnerConfig(4);
  c.model.instruction_features = models::InstructionFeatures::kRxrText;
  c.model.text_feature_dim = 8;
  c.model.num_actions = static_cast<int>(models::kNumLookActions);
  vln::test::TempDir dir;
  FeatureStore store(dir / "store", layoutOf(c), 0.05);
  fillStore(store, c, 4);
  torch::manual_seed(3);
  ImitationLearner learner(models::makePolicy(c.model), c);
  const std::vector<int64_t> indices = {0, 1, 2, 3};
  EpisodeBatch batch = store.loadBatch(indices);
  EXPECT_THAT([&] { learner.update(batch); },
              ::testing::ThrowsMessage<std::invalid_argument>(
                  HasSubstr("the batch carries no text features")));
  batch.text_features = torch::randn({4, 6, 8});
  batch.text_features[1].slice(0, 3).zero_();  // padding
  const double first = learner.update(batch).action_loss;
  double last = first;
  for (int i = 0; i < 40; ++i) last = learner.update(batch).action_loss;
  EXPECT_LT(last, 0.5 * first) << "first " << first << " last " << last;
}

// trainer.instruction_contrast_weight: with every episode's words alike
// the contrast is exactly ln 2 and adds weight x ln 2 to the loss; on
// episodes whose actions only the words tell apart (blank features)
// training with it lowers it far below ln 2 (not to 0: a partner in the
// batch may be of the same kind), and the epochs report it
TEST(ImitationLearnerTest, InstructionContrastMeasuresHowMuchTheWordsDecide) {
  ExperimentConfig c = tinyLearnerConfig(4);
  c.trainer.instruction_contrast_weight = 0.5;
  vln::test::TempDir dir;
  const auto r = models::rgbFeatureShape(c.model);
  const auto d = models::depthFeatureShape(c.model);
  FeatureStore alike(dir / "alike", layoutOf(c), 0.05);
  FeatureStore told(dir / "told", layoutOf(c), 0.05);
  torch::manual_seed(5);
  for (int i = 0; i < 12; ++i) {
    const int kind = i % 3;  // the episode's one action, named by its words
    StoredEpisode e;
    e.key.episode_id = i;
    e.key.slot = i;
    // lengths independent of the kind: batches group similar lengths
    const int T = 4 + (i / 3) % 3;
    e.rgb = torch::zeros({T, r[0], r[1], r[2]});
    e.depth = torch::zeros({T, d[0], d[1], d[2]});
    for (int t = 0; t < T; ++t) {
      const int action = t == T - 1 ? 0 : 1 + kind;
      e.oracle_actions.push_back(static_cast<uint8_t>(action));
      e.prev_actions.push_back(0);  // else it would tell the kind from t = 1
      e.progress.push_back(static_cast<float>(t + 1) / static_cast<float>(T));
    }
    e.tokens = {4, 5, 6};
    alike.append(e);
    e.tokens = {1 + kind, 5, 6};
    told.append(e);
  }

  torch::manual_seed(3);
  ImitationLearner first(models::makePolicy(c.model), c);
  const std::vector<int64_t> four = {0, 1, 2, 3};
  const UpdateResult same = first.update(alike.loadBatch(four));
  EXPECT_NEAR(same.instruction_contrast, std::log(2.0), 1e-6);
  EXPECT_NEAR(same.loss,
              same.action_loss + c.trainer.progress_loss_weight *
                                     same.progress_loss +
                  0.5 * std::log(2.0),
              1e-5);

  torch::manual_seed(3);
  ImitationLearner learner(models::makePolicy(c.model), c);
  const EpochResult start = learner.trainEpoch(told, 1, 0);
  EpochResult end;
  for (int epoch = 1; epoch < 40; ++epoch)
    end = learner.trainEpoch(told, 1, epoch);
  EXPECT_GT(start.mean.instruction_contrast, 0.5);
  EXPECT_LT(end.mean.instruction_contrast, 0.45)
      << "from " << start.mean.instruction_contrast << " action loss "
      << start.mean.action_loss << " -> " << end.mean.action_loss;

  // off: nothing is computed or reported
  c.trainer.instruction_contrast_weight = 0.0;
  torch::manual_seed(3);
  ImitationLearner off(models::makePolicy(c.model), c);
  EXPECT_EQ(off.update(told.loadBatch(four)).instruction_contrast, 0.0);
}

// One accumulated update over `groups` (store indices per batch) against
// one update on their concatenation, from the same initial weights: the
// losses, every gradient and the weights after the step agree to float
// rounding. Adam's first step is about lr * sign(g), so the gradients are
// compared too: a wrong scale would pass the weights' check.
void expectAccumulationExact(const std::vector<std::vector<int64_t>>& groups) {
  ExperimentConfig c = tinyLearnerConfig(4);
  vln::test::TempDir dir;
  FeatureStore store(dir / "store", layoutOf(c), 0.05);
  fillStore(store, c, 8);
  std::vector<EpisodeBatch> batches;
  std::vector<int64_t> all;
  for (const auto& g : groups) {
    batches.push_back(store.loadBatch(g));
    all.insert(all.end(), g.begin(), g.end());
  }
  const EpisodeBatch joined = store.loadBatch(all);

  torch::manual_seed(3);
  ImitationLearner accumulated(models::makePolicy(c.model), c);
  torch::manual_seed(3);
  ImitationLearner single(models::makePolicy(c.model), c);
  const UpdateResult a = accumulated.updateAccumulated(batches);
  const UpdateResult s = single.update(joined);
  ASSERT_FALSE(a.skipped);
  EXPECT_EQ(a.episodes, s.episodes);
  EXPECT_EQ(a.steps, s.steps);
  EXPECT_NEAR(a.loss, s.loss, 1e-5 * std::abs(s.loss));
  EXPECT_NEAR(a.action_loss, s.action_loss, 1e-5 * std::abs(s.action_loss));
  EXPECT_NEAR(a.progress_loss, s.progress_loss,
              1e-5 * std::abs(s.progress_loss));
  EXPECT_NEAR(a.grad_norm, s.grad_norm, 1e-4 * s.grad_norm);
  EXPECT_EQ(accumulated.updates(), 1);

  const auto pa = accumulated.policy().named_parameters();
  const auto ps = single.policy().named_parameters();
  ASSERT_EQ(pa.size(), ps.size());
  int compared = 0;
  for (size_t i = 0; i < pa.size(); ++i) {
    const torch::Tensor& ga = pa[i].value().grad();
    const torch::Tensor& gs = ps[i].value().grad();
    ASSERT_EQ(ga.defined(), gs.defined()) << pa[i].key();
    if (!ga.defined()) continue;
    ++compared;
    EXPECT_TRUE(torch::allclose(ga, gs, /*rtol=*/1e-4, /*atol=*/1e-7))
        << pa[i].key() << ": largest gradient difference "
        << (ga - gs).abs().max().item<double>() << " of "
        << gs.abs().max().item<double>();
    EXPECT_TRUE(torch::allclose(pa[i].value(), ps[i].value(), 1e-5, 1e-7))
        << pa[i].key();
  }
  EXPECT_GT(compared, 4);
}

TEST(ImitationLearnerTest,
     AccumulatedUpdateOfEqualBatchesEqualsTheirConcatenation) {
  expectAccumulationExact({{0, 1, 2, 3}, {4, 5, 6, 7}});
}

// unequal episode and step counts: the batches are weighted by their
// shares, not averaged (averaging is what VLN-CE's division by the number
// of batches does)
TEST(ImitationLearnerTest,
     AccumulatedUpdateOfUnequalBatchesEqualsTheirConcatenation) {
  expectAccumulationExact({{0, 1, 2}, {3, 4}, {7}});
}

TEST(ImitationLearnerTest, AccumulatedUpdateWithANonFiniteBatchIsSkippedWhole) {
  ExperimentConfig c = tinyLearnerConfig(4);
  vln::test::TempDir dir;
  FeatureStore store(dir / "store", layoutOf(c), 0.05);
  fillStore(store, c, 4);
  torch::manual_seed(3);
  ImitationLearner learner(models::makePolicy(c.model), c);
  models::NamedTensors before = models::namedState(learner.policy());
  for (auto& [name, value] : before) value = value.clone();
  // the second batch's loss turns NaN, after the first's backward pass
  int calls = 0;
  learner.setLossHook([&](const torch::Tensor& loss) {
    return ++calls == 2 ? loss * std::nan("") : loss;
  });
  const std::vector<EpisodeBatch> batches = {store.loadBatch({{0, 1}}),
                                             store.loadBatch({{2, 3}})};
  const UpdateResult r = learner.updateAccumulated(batches);
  EXPECT_TRUE(r.skipped);
  EXPECT_EQ(learner.updates(), 0);
  EXPECT_EQ(learner.nonFiniteInARow(), 1);
  const models::NamedTensors after = models::namedState(learner.policy());
  ASSERT_EQ(before.size(), after.size());
  for (size_t i = 0; i < before.size(); ++i)
    EXPECT_TRUE(torch::equal(before[i].second, after[i].second))
        << before[i].first;
  for (const auto& p : learner.policy().parameters())
    EXPECT_TRUE(!p.grad().defined() || p.grad().abs().sum().item<double>() == 0)
        << "gradients of the skipped update remain";
}

}  // namespace
}  // namespace vln::train
