// TrainingData: which splits a VLN run learns from and in which order the
// collection pool holds them (train, aug, then dataset.extra_train_splits),
// with the source tag that keeps their episode ids apart in the store.

#include "train/TrainingData.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "data/Episode.h"
#include "data/GroundTruth.h"
#include "data/Split.h"
#include "support/TestPaths.h"

namespace vln::train {
namespace {

namespace fs = std::filesystem;
using ::testing::ElementsAre;
using ::testing::HasSubstr;

// Writes split `name` with `count` episodes (ids 1..count) and, when
// `withTruth`, a ground truth of one STOP per episode.
void writeSplit(const fs::path& root, const std::string& name, int count,
                bool withTruth = true) {
  data::EpisodeDataset dataset;
  data::GroundTruth truth;
  for (int id = 1; id <= count; ++id) {
    data::Episode e;
    e.episode_id = id;
    e.trajectory_id = id;
    e.scene_id = "procedural/" + name + "/" + name + ".glb";
    e.geodesic_distance = 1.0f;
    e.goals = {data::Goal{}};
    e.reference_path = {Vec3f::Zero(), Vec3f::Zero()};
    e.instruction.instruction_text = name + " episode " + std::to_string(id);
    dataset.episodes.push_back(e);
    truth[id].actions = {sim::Action::kStop};
  }
  data::writeEpisodes(data::splitEpisodesPath(root, name), dataset);
  if (withTruth)
    data::writeGroundTruth(data::splitGroundTruthPath(root, name), truth);
}

ExperimentConfig configFor(const fs::path& root) {
  ExperimentConfig config;
  config.dataset.data_path = root.string();
  config.trainer.use_aug = true;
  return config;
}

TEST(TrainingDataTest, PoolIsTrainThenAugThenEachExtraSplitWithItsSource) {
  test::TempDir dir;
  writeSplit(dir.path(), "train", 3);
  writeSplit(dir.path(), "train_aug", 2);
  writeSplit(dir.path(), "train_extra", 2);
  writeSplit(dir.path(), "more", 1, /*withTruth=*/false);
  ExperimentConfig config = configFor(dir.path());
  config.dataset.extra_train_splits = {"train_extra", "more"};
  config.dataset.max_train_episodes = 2;  // caps train only

  const TrainingData data = TrainingData::load(config);
  ASSERT_EQ(data.pool.size(), 2u + 2u + 2u + 1u);
  EXPECT_THAT(data.sources, ElementsAre(0, 0, 1, 1, 2, 2, 3));
  EXPECT_EQ(data.pool[4], &data.extra[0]->episodes[0]);
  EXPECT_EQ(data.pool[6], &data.extra[1]->episodes[0]);
  EXPECT_EQ(data.pool[6]->instruction.instruction_text, "more episode 1");

  // the inflection frequency sees every ground truth there is
  const auto truths = data.groundTruths();
  ASSERT_EQ(truths.size(), 4u);
  EXPECT_NE(truths[2], nullptr);
  EXPECT_EQ(truths[3], nullptr);  // "more" has no ground-truth file
}

TEST(TrainingDataTest, NoExtraSplitsIsTheOldPool) {
  test::TempDir dir;
  writeSplit(dir.path(), "train", 2);
  writeSplit(dir.path(), "train_aug", 1);
  const TrainingData data = TrainingData::load(configFor(dir.path()));
  EXPECT_TRUE(data.extra.empty());
  EXPECT_THAT(data.sources, ElementsAre(0, 0, 1));
}

TEST(TrainingDataTest, EmptyOrMissingExtraSplitIsAnErrorNamingIt) {
  test::TempDir dir;
  writeSplit(dir.path(), "train", 2);
  writeSplit(dir.path(), "train_aug", 1);
  writeSplit(dir.path(), "empty", 0);
  ExperimentConfig config = configFor(dir.path());
  config.dataset.extra_train_splits = {"empty"};
  try {
    TrainingData::load(config);
    FAIL() << "expected an error";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("dataset.extra_train_splits[0] 'empty'"));
    EXPECT_THAT(e.what(), HasSubstr("has no episodes"));
  }
  config.dataset.extra_train_splits = {"absent"};
  try {
    TrainingData::load(config);
    FAIL() << "expected an error";
  } catch (const std::exception& e) {
    EXPECT_THAT(e.what(), HasSubstr("absent"));
  }
}

}  // namespace
}  // namespace vln::train
