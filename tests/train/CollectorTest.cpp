// Tests of src/train/Collector.cpp on the tiny procedural world: the oracle
// reproduces the split's ground-truth actions, DAgger data does not depend
// on the number of environments, and an interrupted round resumes without
// losing or duplicating slots (bit for bit with trainer.exact_resume).

#include "train/Collector.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <map>

#include "TrainTestWorld.h"
#include "common/Config.h"
#include "common/Math.h"

namespace vln::train {
namespace {

ExperimentConfig worldConfig(const test::TinyWorld& w, int numEnvs) {
  vln::test::TempDir unused;
  ExperimentConfig c = common::loadConfigText<ExperimentConfig>(
      test::tinyRunConfig(w, unused.path(), ""), "tiny run");
  c.task.max_episode_steps = 400;
  c.trainer.num_envs = numEnvs;
  c.trainer.env_threads = 2;
  c.trainer.store_fp16 = false;
  return c;
}

StoreLayout layoutOf(const ExperimentConfig& c) {
  StoreLayout l;
  l.rgb_shape = models::rgbFeatureShape(c.model);
  l.depth_shape = models::depthFeatureShape(c.model);
  l.fp16 = c.trainer.store_fp16;
  l.config_hash = "collector-test";
  return l;
}

struct Fixture {
  const test::TinyWorld& world = test::tinyWorld();
  data::EpisodeDataset train =
      data::readEpisodes(data::splitEpisodesPath(world.data, "train"));
  data::GroundTruth gt =
      data::readGroundTruth(data::splitGroundTruthPath(world.data, "train"));
};

// model.normalize_rgb changes the stored RGB features, so a store written
// with it off must not be reused with it on; stores written before the key
// existed (with ImageNet normalisation) keep their hash
TEST(StoreConfigHashTest, NormalizeRgbEntersOnlyWhenOff) {
  ExperimentConfig c;
  const std::string defaults = storeConfigHash(c);
  // the default config's hash before model.normalize_rgb existed (computed
  // with Collector.cpp of dd5dc7a)
  EXPECT_EQ(defaults, "703427e46e4b299c");
  c.model.normalize_rgb = false;
  EXPECT_NE(storeConfigHash(c), defaults);
  c.model.normalize_rgb = true;
  EXPECT_EQ(storeConfigHash(c), defaults);
}

// the same for the keys added later: look actions and extra training
// splits change what is collected, so they enter the hash, but only away
// from their defaults
TEST(StoreConfigHashTest, LaterKeysEnterOnlyAwayFromTheirDefaults) {
  ExperimentConfig c;
  const std::string defaults = storeConfigHash(c);
  c.sim.agent.tilt_angle = 15.0f;  // unused without look actions
  EXPECT_EQ(storeConfigHash(c), defaults);
  c.sim.agent.look_actions = true;
  const std::string looking = storeConfigHash(c);
  EXPECT_NE(looking, defaults);
  c.sim.agent.tilt_angle = 30.0f;
  EXPECT_NE(storeConfigHash(c), looking);
  c = ExperimentConfig{};
  c.dataset.extra_train_splits = {"train_extra"};
  const std::string extra = storeConfigHash(c);
  EXPECT_NE(extra, defaults);
  c.dataset.extra_train_splits = {"train_extra", "more"};
  EXPECT_NE(storeConfigHash(c), extra);
}

// RxR's dataset keys change which episodes are collected only with
// dataset.format rxr; the text features are read at batch time, never stored
TEST(StoreConfigHashTest, RxrKeysEnterOnlyForRxrRuns) {
  ExperimentConfig c;
  const std::string defaults = storeConfigHash(c);
  c.dataset.rxr_filter.roles = {"*"};
  c.dataset.text_features_dir = "elsewhere";
  EXPECT_EQ(storeConfigHash(c), defaults);
  c = ExperimentConfig{};
  c.dataset.format = "rxr";
  const std::string rxr = storeConfigHash(c);
  EXPECT_NE(rxr, defaults);
  c.dataset.text_features_dir = "elsewhere";
  EXPECT_EQ(storeConfigHash(c), rxr);
  c.dataset.rxr_filter.roles = {"*"};
  const std::string roles = storeConfigHash(c);
  EXPECT_NE(roles, rxr);
  c.dataset.rxr_filter.languages = {"en-US"};
  EXPECT_NE(storeConfigHash(c), roles);
}

// VLN-CE's progress target (habitat_extensions/sensors.py,
// VLNOracleProgressSensor): (d0 - d) / d0, not clipped; 0 when d is inf
TEST(ProgressTargetTest, FollowsVlnCeUnclippedOrClipsOnRequest) {
  for (bool clip : {false, true}) {
    EXPECT_FLOAT_EQ(progressTarget(10.0f, 10.0f, clip), 0.0f);
    EXPECT_FLOAT_EQ(progressTarget(10.0f, 2.5f, clip), 0.75f);
    EXPECT_FLOAT_EQ(progressTarget(10.0f, 0.0f, clip), 1.0f);
    EXPECT_FLOAT_EQ(progressTarget(10.0f, 15.0f, clip), -0.5f);
    EXPECT_FLOAT_EQ(progressTarget(10.0f, INFINITY, clip), 0.0f);
    EXPECT_FLOAT_EQ(progressTarget(0.0f, 1.0f, clip), 0.0f);
  }
  // 35 m away from a goal 10 m from the start: (10 - 35) / 10
  EXPECT_FLOAT_EQ(progressTarget(10.0f, 35.0f, /*clip=*/false), -2.5f);
  EXPECT_FLOAT_EQ(progressTarget(10.0f, 35.0f, /*clip=*/true), -1.0f);
}

// torch.multinomial over one draw by inverse CDF: softmax([0, ln 3]) =
// [0.25, 0.75]
TEST(SampleFromLogitsTest, InvertsTheSoftmaxCdf) {
  const std::vector<float> logits = {0.0f, std::log(3.0f)};
  EXPECT_EQ(sampleFromLogits(logits, 0.0), 0);
  EXPECT_EQ(sampleFromLogits(logits, 0.2499), 0);
  EXPECT_EQ(sampleFromLogits(logits, 0.2501), 1);
  EXPECT_EQ(sampleFromLogits(logits, 0.9999), 1);
  // four actions, one overwhelming: every u picks it; huge logits do not
  // overflow
  const std::vector<float> sure = {1000.0f, -1000.0f, 900.0f, 0.0f};
  for (double u : {0.0, 0.5, 0.999999}) EXPECT_EQ(sampleFromLogits(sure, u), 0);
  // frequencies of a fine grid of u follow the probabilities
  const std::vector<float> four = {0.0f, 1.0f, 2.0f, 0.5f};
  std::vector<int> counts(4, 0);
  const int n = 100000;
  for (int i = 0; i < n; ++i)
    ++counts[static_cast<size_t>(sampleFromLogits(four, (i + 0.5) / n))];
  double total = 0.0;
  for (float l : four) total += std::exp(static_cast<double>(l));
  for (size_t a = 0; a < 4; ++a)
    EXPECT_NEAR(counts[a] / static_cast<double>(n),
                std::exp(static_cast<double>(four[a])) / total, 1e-4);
}

// The expert itself (goal vs reference path on a corridor, VLN-CE's golden
// actions) is rollout::WaypointOracle's, tested in
// tests/rollout/WaypointOracleTest.cpp.

// trainer.expert names the oracle's waypoints; a wrong value says which key.
TEST(ExpertWaypointsTest, NamesTheKeyOfAnUnknownExpert) {
  data::Episode e;
  e.episode_id = 7;
  for (float x : {1.0f, 6.0f, 9.0f})
    e.reference_path.push_back(Vec3f(x, 0.0f, 1.0f));
  e.start_position = e.reference_path.front();
  e.goals.push_back({e.reference_path.back(), 3.0f});
  EXPECT_EQ(expertWaypoints(e, "goal"),
            std::vector<Vec3f>{e.reference_path.back()});
  EXPECT_EQ(expertWaypoints(e, "reference_path").size(), 3u);
  EXPECT_THAT([&] { (void)expertWaypoints(e, "nearest"); },
              ::testing::ThrowsMessage<std::invalid_argument>(
                  ::testing::HasSubstr("trainer.expert")));
}

TEST(CollectorTest, TeacherForcingReproducesTheGroundTruthActions) {
  Fixture f;
  ExperimentConfig c = worldConfig(f.world, 3);
  c.trainer.expert = "reference_path";
  vln::test::TempDir dir;
  FeatureStore store(dir / "store", layoutOf(c), 0.25);
  models::ObservationEncoder encoder(c.model);
  Collector collector(c, std::make_shared<rollout::SceneCache>(c.sim), encoder);
  CollectionRound round;
  for (const auto& e : f.train.episodes) {
    round.episodes.push_back(&e);
    round.sources.push_back(0);
  }
  const CollectionStats stats = collector.collect(round, store, nullptr, &f.gt);
  ASSERT_EQ(stats.episodes, static_cast<int64_t>(f.train.episodes.size()));
  EXPECT_EQ(store.size(), stats.episodes);
  EXPECT_EQ(stats.gt_episodes, stats.episodes);
  EXPECT_EQ(stats.gt_identical, stats.gt_episodes)
      << stats.gt_equal_steps << " of " << stats.gt_steps << " steps agree";
  EXPECT_EQ(stats.oracle_steps, stats.steps);
  EXPECT_EQ(stats.cut_at_limit, 0);

  // every stored episode: labels = ground truth, prev actions = labels
  // shifted (the oracle's own trajectory), progress ends near 1
  for (int64_t i = 0; i < store.size(); ++i) {
    const StoredEpisode e = store.read(i);
    const auto& actions = f.gt.at(static_cast<int>(e.key.episode_id)).actions;
    ASSERT_EQ(e.oracle_actions.size(), actions.size());
    EXPECT_EQ(e.prev_actions[0], 0);
    for (size_t t = 1; t < actions.size(); ++t)
      EXPECT_EQ(e.prev_actions[t], e.oracle_actions[t - 1]);
    EXPECT_EQ(e.oracle_actions.back(), 0);
    EXPECT_GT(e.progress.back(), 0.5f);
    EXPECT_NEAR(e.progress.front(), 0.0f, 0.05f);
    EXPECT_EQ(e.rgb.size(0), e.length());
    EXPECT_FALSE(e.tokens.empty());
  }
}

// DAgger with a random policy: same data whatever the environment count,
// and an interrupted round completes without duplicates
// One DAgger round (beta 0.5, 6 slots) collected twice: (a) in one go with
// 2 environments, (b) with 3 environments by a run that had stored slots 1
// and 4 before it was interrupted. Returns both stores' episodes by slot.
struct TwoCollections {
  std::map<int32_t, StoredEpisode> uninterrupted, resumed;
};

TwoCollections collectTwice(bool exactResume) {
  Fixture f;
  torch::manual_seed(4);
  ExperimentConfig c2 = worldConfig(f.world, 2);
  c2.task.max_episode_steps = 60;
  c2.trainer.exact_resume = exactResume;
  ExperimentConfig c3 = c2;
  c3.trainer.num_envs = 3;
  auto policy = models::makePolicy(c2.model);
  models::ObservationEncoder encoder(c2.model);
  auto scenes = std::make_shared<rollout::SceneCache>(c2.sim);

  CollectionRound round;
  round.iteration = 2;
  round.beta = 0.5;
  round.seed = 9;
  for (size_t k = 0; k < 6; ++k) {
    round.episodes.push_back(&f.train.episodes[k % f.train.episodes.size()]);
    round.sources.push_back(0);
  }

  vln::test::TempDir dir;
  FeatureStore a(dir / "a", layoutOf(c2), 0.25);
  Collector(c2, scenes, encoder).collect(round, a, policy, nullptr);
  FeatureStore b(dir / "b", layoutOf(c3), 0.25);
  {
    FeatureStore scratch(dir / "scratch", layoutOf(c3), 0.25);
    Collector(c3, scenes, encoder).collect(round, scratch, policy, nullptr);
    for (int64_t i = 0; i < scratch.size(); ++i) {
      const StoredEpisode e = scratch.read(i);
      if (e.key.slot == 1 || e.key.slot == 4) b.append(e);
    }
  }
  EXPECT_EQ(b.size(), 2);
  const CollectionStats resumed =
      Collector(c3, scenes, encoder).collect(round, b, policy, nullptr);
  EXPECT_EQ(resumed.skipped, 2);
  EXPECT_EQ(resumed.episodes, 4);
  EXPECT_EQ(b.slots(2), (std::set<int32_t>{0, 1, 2, 3, 4, 5}));

  TwoCollections out;
  for (int64_t i = 0; i < a.size(); ++i)
    out.uninterrupted[a.key(i).slot] = a.read(i);
  for (int64_t i = 0; i < b.size(); ++i) out.resumed[b.key(i).slot] = b.read(i);
  return out;
}

// steps whose action came from the policy rather than the oracle
int64_t policySteps(const std::map<int32_t, StoredEpisode>& episodes) {
  int64_t n = 0;
  for (const auto& [slot, e] : episodes)
    for (size_t t = 1; t < e.prev_actions.size(); ++t)
      n += e.prev_actions[t] != e.oracle_actions[t - 1];
  return n;
}

// the same episodes, labels and actions in both collections; features
// equal bit for bit, or (batched) up to the rounding of other batch shapes
void expectSameEpisodes(const TwoCollections& two, bool bitExact) {
  ASSERT_EQ(two.uninterrupted.size(), 6u);
  ASSERT_EQ(two.resumed.size(), 6u);
  for (int32_t k = 0; k < 6; ++k) {
    const StoredEpisode& x = two.uninterrupted.at(k);
    const StoredEpisode& y = two.resumed.at(k);
    EXPECT_EQ(x.key.episode_id, y.key.episode_id);
    EXPECT_EQ(x.prev_actions, y.prev_actions) << "slot " << k;
    EXPECT_EQ(x.oracle_actions, y.oracle_actions) << "slot " << k;
    if (bitExact) {
      EXPECT_EQ(x.progress, y.progress) << "slot " << k;
      EXPECT_TRUE(torch::equal(x.rgb, y.rgb)) << "slot " << k;
      EXPECT_TRUE(torch::equal(x.depth, y.depth)) << "slot " << k;
    } else {
      EXPECT_TRUE(torch::allclose(x.depth, y.depth, 1e-4, 1e-5))
          << "slot " << k;
    }
  }
  // with beta = 0.5 some actions came from the (untrained) policy
  EXPECT_GT(policySteps(two.uninterrupted), 0);
}

TEST(CollectorTest, DaggerRoundIsIndependentOfEnvCountAndResumes) {
  expectSameEpisodes(collectTwice(/*exactResume=*/false), /*bitExact=*/false);
}

TEST(CollectorTest, ExactResumeStoresBitIdenticalFeatures) {
  expectSameEpisodes(collectTwice(/*exactResume=*/true), /*bitExact=*/true);
}

}  // namespace
}  // namespace vln::train
