// TrainingData: which splits a VLN run learns from and in which order the
// collection pool holds them (train, aug, then dataset.extra_train_splits),
// with the source tag that keeps their episode ids apart in the store.

#include "train/TrainingData.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <torch/torch.h>

#include <filesystem>
#include <string>

#include "data/Episode.h"
#include "data/GroundTruth.h"
#include "data/RxrEpisodes.h"
#include "data/RxrTextFeatures.h"
#include "data/Split.h"
#include "support/TestPaths.h"
#include "train/FeatureStore.h"

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

TEST(TrainingDataTest, RandomWordEmbeddingsNeedNoFileAndFollowTheSeed) {
  test::TempDir dir;  // no embeddings file: GloVe would fail to load
  ExperimentConfig config = configFor(dir.path());
  config.model.vocab_size = 9;
  config.model.embedding_dim = 4;
  EXPECT_THROW(embeddingTensor(config), std::exception);
  config.model.word_embeddings = models::WordEmbeddings::kRandom;
  config.trainer.seed = 3;
  const torch::Tensor a = embeddingTensor(config);
  EXPECT_EQ(a.sizes(), (std::vector<int64_t>{9, 4}));
  EXPECT_TRUE(torch::equal(a, embeddingTensor(config)));
  config.trainer.seed = 4;
  EXPECT_FALSE(torch::equal(a, embeddingTensor(config)));
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

// ---------------------------------------------------------------------------
// dataset.format: rxr

// Writes RxR split `name` for `role`: episodes `ids` with instruction ids
// 100 + id, alternately en-US and en-IN, and a ground truth of one STOP each.
void writeRxrSplit(const fs::path& root, const std::string& name,
                   const std::string& role, const std::vector<int>& ids) {
  data::EpisodeDataset dataset;
  data::GroundTruth truth;
  for (int id : ids) {
    data::Episode e;
    e.episode_id = id;
    e.trajectory_id = id;
    e.scene_id = "procedural/h/h.glb";
    e.goals = {data::Goal{}};
    e.reference_path = {Vec3f::Zero(), Vec3f::Zero()};
    e.instruction.instruction_text = "walk " + std::to_string(id);
    e.instruction.instruction_id = 100 + id;
    e.instruction.language = id % 2 ? "en-US" : "en-IN";
    dataset.episodes.push_back(e);
    truth[id].actions = {sim::Action::kStop};
  }
  fs::create_directories(root / name);
  data::writeEpisodes(data::rxrEpisodesPath(root, name, role), dataset);
  data::writeGroundTruth(data::rxrGroundTruthPath(root, name, role), truth);
}

// Text features of instruction 100 + id: `rows` rows of width 4, every
// value id + row / 10 (so each file tells which episode it belongs to).
void writeFeatures(const fs::path& root, const std::string& split, int id,
                   int rows) {
  std::vector<float> values;
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < 4; ++c)
      values.push_back(static_cast<float>(id) + static_cast<float>(r) / 10.0f);
  data::writeRxrTextFeatures(
      data::rxrTextFeaturesPath(root / "text_features", split, 100 + id,
                                id % 2 ? "en-US" : "en-IN"),
      values, 4);
}

ExperimentConfig rxrConfigFor(const fs::path& root) {
  ExperimentConfig config;
  config.dataset.format = "rxr";
  config.dataset.data_path = root.string();
  config.model.instruction_features = models::InstructionFeatures::kRxrText;
  config.model.text_feature_dim = 4;
  return config;
}

TEST(TrainingDataTest, RxrFormatReadsTheFilteredRolesWithTheirGroundTruth) {
  test::TempDir dir;
  writeRxrSplit(dir.path(), "train", "guide", {1, 2, 3});
  writeRxrSplit(dir.path(), "train", "follower", {7});
  ExperimentConfig config = rxrConfigFor(dir.path());
  TrainingData td = TrainingData::load(config);
  ASSERT_EQ(td.pool.size(), 3u);  // VLN-CE's default roles: guide
  EXPECT_EQ(td.pool[2]->instruction.instruction_id, 103);
  ASSERT_NE(td.train.groundTruth, nullptr);
  EXPECT_EQ(td.train.groundTruth->size(), 3u);
  EXPECT_EQ(&td.episode(0, 2), td.pool[1]);
  EXPECT_THROW(td.episode(0, 7), std::invalid_argument);

  config.dataset.rxr_filter.roles = {"*"};
  config.dataset.rxr_filter.languages = {"en-US"};
  td = TrainingData::load(config);
  std::vector<int> ids;
  for (const data::Episode* e : td.pool) ids.push_back(e->episode_id);
  EXPECT_THAT(ids, ElementsAre(1, 3, 7));
  EXPECT_EQ(td.train.groundTruth->size(), 4u);  // both roles' files
}

// the store keeps (source, episode id); batches get the episodes' feature
// files by them, in batch order, zero-padded to the longest
TEST(TrainingDataTest, BatchTextFeaturesReadTheStoredEpisodesFiles) {
  test::TempDir dir;
  writeRxrSplit(dir.path(), "train", "guide", {1, 2, 3});
  writeFeatures(dir.path(), "train", 1, 2);
  writeFeatures(dir.path(), "train", 2, 5);
  writeFeatures(dir.path(), "train", 3, 1);
  ExperimentConfig config = rxrConfigFor(dir.path());
  const TrainingData td = TrainingData::load(config);

  FeatureStore store(dir.path() / "store", StoreLayout{}, 0.01);
  for (int id : {3, 1, 2}) {
    StoredEpisode e;
    e.key.episode_id = id;
    e.key.slot = id;
    e.prev_actions = {0};
    e.oracle_actions = {0};
    e.progress = {0.0f};
    store.append(e);
  }
  const std::vector<int64_t> indices = {1, 0, 2};  // episodes 1, 3, 2
  const torch::Tensor batch = td.batchTextFeatures(config, store, indices);
  ASSERT_EQ(batch.sizes(), (std::vector<int64_t>{3, 5, 4}));
  EXPECT_FLOAT_EQ(batch[0][1][0].item<float>(), 1.1f);
  EXPECT_FLOAT_EQ(batch[0][2][0].item<float>(), 0.0f);  // padding
  EXPECT_FLOAT_EQ(batch[1][0][3].item<float>(), 3.0f);
  EXPECT_FLOAT_EQ(batch[2][4][2].item<float>(), 2.4f);
  // dataset.max_instruction_length caps the rows
  config.dataset.max_instruction_length = 3;
  EXPECT_EQ(td.batchTextFeatures(config, store, indices).size(1), 3);

  // the same files through the collection source, by pool episode
  const auto source = td.textFeatureSource(config);
  EXPECT_EQ(source(*td.pool[1]).size(0), 5);
}

TEST(TrainingDataTest, MissingTextFeatureFileNamesTheFileAndTheEpisode) {
  test::TempDir dir;
  writeRxrSplit(dir.path(), "train", "guide", {1, 2});
  writeFeatures(dir.path(), "train", 1, 2);
  const ExperimentConfig config = rxrConfigFor(dir.path());
  const TrainingData td = TrainingData::load(config);
  try {
    td.textFeatureSource(config)(*td.pool[1]);
    FAIL() << "expected an error";
  } catch (const std::runtime_error& e) {
    EXPECT_THAT(e.what(), HasSubstr("episode 2"));
    EXPECT_THAT(e.what(), HasSubstr("instruction_id 102"));
    EXPECT_THAT(e.what(), HasSubstr("rxr_train/000102_en_text_features.npz"));
    EXPECT_THAT(e.what(), HasSubstr("does not exist"));
  }
  // checked up front for a whole split
  try {
    rollout::requireRxrTextFeatureFiles(config.dataset.textFeaturesPath(),
                                        "train", td.pool);
    FAIL() << "expected an error";
  } catch (const std::runtime_error& e) {
    EXPECT_THAT(e.what(), HasSubstr("1 of 2 files are missing"));
    EXPECT_THAT(e.what(), HasSubstr("000102_en_text_features.npz' (episode 2"));
  }
}

}  // namespace
}  // namespace vln::train
