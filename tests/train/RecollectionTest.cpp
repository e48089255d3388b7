// Tests of src/train/Recollection.cpp on the tiny procedural world: the
// ground truth's actions, replayed in the generated houses, reproduce its
// locations and are the labels; trainer.max_traj_len leaves long episodes
// out (VLN-CE skips them, it does not cut them); ground truth that cannot
// be replayed is refused up front; the recollect keys stay out of the
// feature store's hash.

#include "train/Recollection.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>

#include "TrainTestWorld.h"
#include "common/Config.h"
#include "train/Collector.h"

namespace vln::train {
namespace {

using ::testing::HasSubstr;

ExperimentConfig worldConfig(const test::TinyWorld& w) {
  vln::test::TempDir unused;
  ExperimentConfig c = common::loadConfigText<ExperimentConfig>(
      test::tinyRunConfig(w, unused.path(), "  mode: recollect\n"), "tiny run");
  c.task.max_episode_steps = 400;
  c.trainer.env_threads = 2;
  return c;
}

models::ObservationEncoder encoderOf(const ExperimentConfig& c) {
  torch::manual_seed(0);
  models::ObservationEncoder encoder(c.model);
  encoder->loadPretrained();
  return encoder;
}

TEST(RecollectionTest, ReplayedGroundTruthReproducesItsLocationsAndLabels) {
  const test::TinyWorld& w = test::tinyWorld();
  const ExperimentConfig c = worldConfig(w);
  const TrainingData data = TrainingData::load(c);
  const RecollectionPool pool = recollectionPool(data, c);
  ASSERT_EQ(pool.episodes.size(), data.train.episodes.size());
  EXPECT_EQ(pool.without_ground_truth, 0);
  EXPECT_EQ(pool.over_max_traj_len, 0);

  auto scenes = std::make_shared<rollout::SceneCache>(c.sim);
  Recollector recollector(c, scenes, encoderOf(c));
  ReplayStats stats;
  const std::vector<RecollectedEpisode> out =
      recollector.replay(pool.episodes, &stats);
  ASSERT_EQ(out.size(), pool.episodes.size());
  int64_t steps = 0;
  int moves = 0;
  for (size_t i = 0; i < out.size(); ++i) {
    const RecollectEpisode& e = pool.episodes[i];
    const data::GroundTruthPath& truth = *e.ground_truth;
    const StoredEpisode& s = out[i].stored;
    SCOPED_TRACE(::testing::Message() << "episode " << e.episode->episode_id);
    EXPECT_EQ(s.key.episode_id, e.episode->episode_id);
    EXPECT_EQ(s.key.slot, static_cast<int32_t>(i));
    // the labels are the ground truth, the previous actions follow it
    ASSERT_EQ(s.oracle_actions.size(), truth.actions.size());
    for (size_t t = 0; t < truth.actions.size(); ++t) {
      EXPECT_EQ(s.oracle_actions[t], static_cast<uint8_t>(truth.actions[t]));
      EXPECT_EQ(s.prev_actions[t],
                t == 0 ? 0 : static_cast<uint8_t>(truth.actions[t - 1]));
    }
    // the agent went where the ground truth says, position by position
    ASSERT_EQ(out[i].positions.size(), truth.locations.size());
    for (size_t k = 0; k < truth.locations.size(); ++k)
      EXPECT_LT((out[i].positions[k] - truth.locations[k]).norm(), 1e-4f)
          << "location " << k;
    moves += static_cast<int>(truth.locations.size()) - 1;
    // a feature row per step, and the progress target ends near 1
    EXPECT_EQ(s.rgb.size(0), s.length());
    EXPECT_EQ(s.depth.size(0), s.length());
    EXPECT_GT(s.progress.back(), 0.5f);
    steps += s.length();
  }
  EXPECT_GT(moves, 10);
  EXPECT_EQ(stats.episodes, static_cast<int64_t>(out.size()));
  EXPECT_EQ(stats.steps, steps);
  EXPECT_EQ(stats.off_ground_truth, 0);
  EXPECT_LT(stats.max_location_error, 1e-4);

  // the same episodes again: the same features (nothing is random)
  const std::vector<RecollectedEpisode> again =
      recollector.replay(pool.episodes, nullptr);
  for (size_t i = 0; i < out.size(); ++i)
    EXPECT_TRUE(torch::equal(out[i].stored.depth, again[i].stored.depth));
}

TEST(RecollectionTest, CompareLocationsNeedsTheSameCountAndCloseness) {
  const std::vector<Vec3f> a = {Vec3f(0, 0, 0), Vec3f(0.25f, 0, 0)};
  const std::vector<Vec3f> b = {Vec3f(0, 0, 0), Vec3f(0.25f, 0, 0.005f)};
  EXPECT_TRUE(compareLocations(a, b, 0.01).same);
  EXPECT_NEAR(compareLocations(a, b, 0.01).max_error, 0.005, 1e-6);
  EXPECT_FALSE(compareLocations(a, b, 0.001).same);
  EXPECT_FALSE(compareLocations(a, {b.data(), 1}, 1.0).same);
}

TEST(RecollectionTest, MaxTrajLenLeavesLongerEpisodesOut) {
  const test::TinyWorld& w = test::tinyWorld();
  ExperimentConfig c = worldConfig(w);
  const TrainingData data = TrainingData::load(c);
  std::vector<int> lengths;
  for (const auto& [id, path] : *data.train.groundTruth)
    lengths.push_back(static_cast<int>(path.actions.size()));
  std::sort(lengths.begin(), lengths.end());
  // a limit between the lengths: exactly the longer episodes go, whole
  const int limit = lengths[lengths.size() / 2];
  const auto longer = std::count_if(lengths.begin(), lengths.end(),
                                    [&](int n) { return n > limit; });
  ASSERT_GT(longer, 0);
  c.trainer.max_traj_len = limit;
  const RecollectionPool pool = recollectionPool(data, c);
  EXPECT_EQ(pool.over_max_traj_len, longer);
  EXPECT_EQ(static_cast<int64_t>(pool.episodes.size()),
            static_cast<int64_t>(lengths.size()) - longer);
  for (const RecollectEpisode& e : pool.episodes) {
    EXPECT_LE(e.length(), limit);
    // kept episodes are whole, STOP last
    EXPECT_EQ(e.ground_truth->actions.back(), sim::Action::kStop);
  }
  // below every length nothing is left: an error naming the key
  c.trainer.max_traj_len = 1;
  EXPECT_THAT([&] { recollectionPool(data, c); },
              ::testing::ThrowsMessage<std::invalid_argument>(
                  HasSubstr("trainer.max_traj_len = 1")));
}

TEST(RecollectionTest, GroundTruthThatCannotBeReplayedIsRefused) {
  const test::TinyWorld& w = test::tinyWorld();
  ExperimentConfig c = worldConfig(w);
  const TrainingData data = TrainingData::load(c);
  const int id = data.train.episodes.front().episode_id;
  auto edited = [&](auto edit) {
    TrainingData copy = TrainingData::load(c);
    edit((*copy.train.groundTruth)[id].actions);
    return copy;
  };
  const TrainingData noStop = edited([](auto& a) { a.pop_back(); });
  EXPECT_THAT(
      [&] { recollectionPool(noStop, c); },
      ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("not STOP")));
  const TrainingData earlyStop =
      edited([](auto& a) { a.front() = sim::Action::kStop; });
  EXPECT_THAT([&] { recollectionPool(earlyStop, c); },
              ::testing::ThrowsMessage<std::invalid_argument>(
                  HasSubstr("STOP before the last")));
  const TrainingData look =
      edited([](auto& a) { a.front() = sim::Action::kLookUp; });
  EXPECT_THAT([&] { recollectionPool(look, c); },
              ::testing::ThrowsMessage<std::invalid_argument>(
                  HasSubstr("outside the 4 actions")));
  // longer than the episode step limit: the error names both keys
  c.task.max_episode_steps = 3;
  EXPECT_THAT([&] { recollectionPool(data, c); },
              ::testing::ThrowsMessage<std::invalid_argument>(
                  AllOf(HasSubstr("task.max_episode_steps = 3"),
                        HasSubstr("trainer.max_traj_len"))));
}

// the store's trainer never reads the recollect keys, so they must not
// change its hash (stores written before they existed stay usable)
TEST(RecollectionTest, RecollectKeysStayOutOfTheStoreHash) {
  ExperimentConfig c;
  const std::string defaults = storeConfigHash(c);
  c.trainer.mode = "recollect";
  c.trainer.effective_batch_size = 10;
  c.trainer.max_traj_len = 250;
  c.trainer.preload_size = 60;
  EXPECT_EQ(storeConfigHash(c), defaults);
}

TEST(RecollectionTest, ConfigChecksTheRecollectKeys) {
  auto expectRefused = [](const std::function<void(ExperimentConfig&)>& edit,
                          const std::string& message) {
    ExperimentConfig c;
    edit(c);
    EXPECT_THAT(
        [&] { c.validate(); },
        ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr(message)));
  };
  expectRefused([](auto& c) { c.trainer.effective_batch_size = 10; },
                "apply to trainer.mode recollect only");
  expectRefused(
      [](auto& c) {
        c.trainer.mode = "recollect";
        c.trainer.dagger_iterations = 2;
      },
      "trainer.dagger_iterations must be 0");
  expectRefused(
      [](auto& c) {
        c.trainer.mode = "recollect";
        c.trainer.batch_size = 4;
        c.trainer.effective_batch_size = 10;
      },
      "positive multiple of trainer.batch_size (4)");
  expectRefused(
      [](auto& c) {
        c.trainer.mode = "recollect";
        c.trainer.batch_size = 40;
        c.trainer.preload_size = 30;
      },
      "trainer.preload_size (30) must be at least trainer.batch_size (40)");
  ExperimentConfig ok;
  ok.trainer.mode = "recollect";
  ok.trainer.batch_size = 4;
  ok.trainer.effective_batch_size = 12;
  ok.trainer.max_traj_len = 250;
  EXPECT_NO_THROW(ok.validate());
}

}  // namespace
}  // namespace vln::train
