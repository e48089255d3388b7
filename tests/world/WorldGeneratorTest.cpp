#include "world/WorldGenerator.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "common/Config.h"
#include "common/FileIo.h"
#include "common/Json.h"
#include "data/Episode.h"
#include "data/Glove.h"
#include "data/GroundTruth.h"
#include "data/NavGraph.h"
#include "data/Split.h"
#include "data/SubInstructions.h"
#include "data/Vocabulary.h"
#include "sim/Agent.h"
#include "sim/Scene.h"
#include "support/TestPaths.h"
#include "world/WorldCommands.h"

namespace vln::world {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

const fs::path kTinyConfig =
    test::sourcePath() / "configs" / "world" / "tiny.yaml";

WorldConfig tinyConfig() {
  return common::loadConfigFile<WorldConfig>(kTinyConfig);
}

// Relative path -> contents of every regular file under `root`.
std::map<std::string, std::string> readTree(const fs::path& root) {
  std::map<std::string, std::string> files;
  for (const auto& entry : fs::recursive_directory_iterator(root))
    if (entry.is_regular_file())
      files[fs::relative(entry.path(), root).string()] =
          common::readFile(entry.path());
  return files;
}

// One tiny world shared by the tests of this file (generation is the slow
// part; each test reads it).
class WorldGeneratorTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new test::TempDir();
    WorldOutput output{dir_->path() / "data", dir_->path() / "scenes", 2};
    std::ostringstream log;
    summary_ = new WorldSummary(generateWorld(tinyConfig(), output, &log));
    log_ = new std::string(log.str());
  }
  static void TearDownTestSuite() {
    delete summary_;
    delete log_;
    delete dir_;
  }
  static fs::path datasetRoot() { return dir_->path() / "data"; }
  static fs::path scenes() { return dir_->path() / "scenes"; }

  static test::TempDir* dir_;
  static WorldSummary* summary_;
  static std::string* log_;
};

test::TempDir* WorldGeneratorTest::dir_ = nullptr;
WorldSummary* WorldGeneratorTest::summary_ = nullptr;
std::string* WorldGeneratorTest::log_ = nullptr;

TEST_F(WorldGeneratorTest, WritesEverySplitInThePublicLayout) {
  for (const std::string& split : worldSplitNames()) {
    const data::EpisodeDataset dataset =
        data::readEpisodes(data::splitEpisodesPath(datasetRoot(), split));
    EXPECT_FALSE(dataset.episodes.empty()) << split;
    ASSERT_TRUE(dataset.instruction_vocab.has_value());
    EXPECT_EQ(static_cast<int>(dataset.episodes.size()),
              summary_->episodes.at(split));
    const bool test = split == "test";
    EXPECT_EQ(fs::exists(data::splitGroundTruthPath(datasetRoot(), split)),
              !test)
        << split;
    std::set<int> ids;
    for (const data::Episode& e : dataset.episodes) {
      EXPECT_TRUE(ids.insert(e.episode_id).second);
      EXPECT_THAT(e.scene_id, ::testing::StartsWith("procedural/house_"));
      EXPECT_TRUE(fs::exists(scenes() / e.scene_id)) << e.scene_id;
      EXPECT_EQ(e.instruction.instruction_tokens.size(), 200u);
      // the test split hides the answers, as the real one does
      EXPECT_EQ(e.goals.empty(), test);
      EXPECT_EQ(e.reference_path.empty(), test);
      EXPECT_EQ(!e.geodesic_distance.has_value(), test);
      if (test) continue;
      EXPECT_EQ(e.goals.front().position, e.reference_path.back());
      EXPECT_EQ(e.goals.front().radius, 3.0f);
      EXPECT_EQ(e.start_position, e.reference_path.front());
      EXPECT_GE(e.reference_path.size(), 4u);
      EXPECT_LE(e.reference_path.size(), 7u);
      EXPECT_GT(*e.geodesic_distance, 0.0f);
    }
  }
  // train episodes come in threes per trajectory, train_aug in ones
  const auto train =
      data::readEpisodes(data::splitEpisodesPath(datasetRoot(), "train"));
  std::map<int, int> perTrajectory;
  for (const data::Episode& e : train.episodes)
    ++perTrajectory[e.trajectory_id];
  for (const auto& [id, count] : perTrajectory) EXPECT_EQ(count, 3) << id;
  const auto aug =
      data::readEpisodes(data::splitEpisodesPath(datasetRoot(), "train_aug"));
  std::set<int> augTrajectories;
  for (const data::Episode& e : aug.episodes)
    EXPECT_TRUE(augTrajectories.insert(e.trajectory_id).second);

  // nav-graphs, embeddings and statistics beside the splits
  EXPECT_TRUE(fs::exists(datasetRoot() / "generation_stats.json"));
  const auto stats =
      common::readJsonFile(datasetRoot() / "generation_stats.json");
  EXPECT_GT(stats.at("transfer").at("node_transfer_rate").get<double>(), 0.8);
  EXPECT_GT(stats.at("transfer").at("trajectories_navigable").get<int>(), 0);
  int graphs = 0;
  for (const auto& entry :
       fs::directory_iterator(datasetRoot() / "connectivity")) {
    const data::NavGraph g = data::readNavGraph(entry.path());
    EXPECT_GT(g.numNodes(), 5);
    ++graphs;
  }
  EXPECT_EQ(graphs, 3);
  const data::EmbeddingMatrix embeddings =
      data::readEmbeddingsJson(datasetRoot() / "embeddings.json.gz");
  EXPECT_EQ(embeddings.rows, train.instruction_vocab->size());
  EXPECT_EQ(embeddings.dim, 16);
  EXPECT_THAT(*log_, HasSubstr("paper 98.3%"));
  // no staging left behind
  for (const auto& entry : fs::directory_iterator(datasetRoot()))
    EXPECT_THAT(entry.path().filename().string(),
                ::testing::Not(HasSubstr(".generate-")));
}

TEST_F(WorldGeneratorTest, SubInstructionsAreWrittenForTheTrainingSplitsOnly) {
  for (const std::string& split : worldSplitNames()) {
    const fs::path file = data::splitSubInstructionsPath(datasetRoot(), split);
    const bool training = split == "train" || split == "train_aug";
    ASSERT_EQ(fs::exists(file), training) << split;
    if (!training) continue;
    const data::EpisodeDataset dataset =
        data::readEpisodes(data::splitEpisodesPath(datasetRoot(), split));
    const data::SubInstructions subs = data::readSubInstructions(file);
    EXPECT_EQ(subs.size(), dataset.episodes.size()) << split;
    EXPECT_NO_THROW(data::checkSubInstructions(subs, dataset.episodes, split));
    for (const data::Episode& e : dataset.episodes) {
      const auto& list = subs.at(e.episode_id);
      ASSERT_FALSE(list.empty()) << e.episode_id;
      // the last clause is the stop, at the reference path's last point
      EXPECT_EQ(list.back().leg, static_cast<int>(e.reference_path.size()) - 1)
          << e.instruction.instruction_text;
    }
  }
}

// splits.evaluation_sub_instructions adds the validation splits' files
// (never test's, public or hidden) and changes no other byte
TEST_F(WorldGeneratorTest, EvaluationSubInstructionsAreNewFilesOnly) {
  test::TempDir more;
  WorldConfig config = tinyConfig();
  config.splits.evaluation_sub_instructions = true;
  generateWorld(config, {more.path() / "data", more.path() / "scenes", 2});
  const fs::path root = more.path() / "data";
  auto before = readTree(datasetRoot());
  const auto after = readTree(root);
  before.erase("generation_stats.json");
  for (const auto& [name, bytes] : before) {
    ASSERT_TRUE(after.count(name)) << name;
    EXPECT_TRUE(after.at(name) == bytes) << name << " changed";
  }
  std::set<std::string> added;
  for (const auto& [name, bytes] : after)
    if (!before.count(name) && name != "generation_stats.json")
      added.insert(name);
  EXPECT_EQ(added, (std::set<std::string>{
                       "val_seen/val_seen_sub_instructions.json.gz",
                       "val_unseen/val_unseen_sub_instructions.json.gz"}));
  for (const std::string split : {"val_seen", "val_unseen"}) {
    const data::EpisodeDataset dataset =
        data::readEpisodes(data::splitEpisodesPath(root, split));
    const data::SubInstructions subs =
        data::readSubInstructions(data::splitSubInstructionsPath(root, split));
    EXPECT_EQ(subs.size(), dataset.episodes.size()) << split;
    EXPECT_NO_THROW(data::checkSubInstructions(subs, dataset.episodes, split));
  }
}

TEST_F(WorldGeneratorTest, TestGoalsAndGroundTruthGoToTheHiddenFolderOnly) {
  // hidden/test/ holds the test episodes as the public file has them, plus
  // the goals, geodesic distances and reference paths it lacks
  const data::EpisodeDataset published =
      data::readEpisodes(data::splitEpisodesPath(datasetRoot(), "test"));
  const data::EpisodeDataset hidden =
      data::readEpisodes(data::hiddenGoalsPath(datasetRoot(), "test"));
  const data::GroundTruth truth =
      data::readGroundTruth(data::hiddenGroundTruthPath(datasetRoot(), "test"));
  EXPECT_EQ(hidden.instruction_vocab, published.instruction_vocab);
  ASSERT_EQ(hidden.episodes.size(), published.episodes.size());
  ASSERT_FALSE(hidden.episodes.empty());
  EXPECT_EQ(truth.size(), hidden.episodes.size());
  for (size_t i = 0; i < hidden.episodes.size(); ++i) {
    const data::Episode& h = hidden.episodes[i];
    data::Episode stripped = h;
    stripped.goals.clear();
    stripped.reference_path.clear();
    stripped.geodesic_distance.reset();
    EXPECT_EQ(stripped, published.episodes[i]) << "episode " << h.episode_id;
    ASSERT_EQ(h.goals.size(), 1u);
    EXPECT_EQ(h.goals.front().position, h.reference_path.back());
    EXPECT_EQ(h.start_position, h.reference_path.front());
    EXPECT_GT(h.geodesic_distance.value_or(0.0f), 0.0f);
    ASSERT_TRUE(truth.contains(h.episode_id));
    EXPECT_EQ(truth.at(h.episode_id).locations.front(), h.start_position);
    EXPECT_EQ(truth.at(h.episode_id).actions.back(), sim::Action::kStop);
  }

  // attached, they make the test split a scored one
  data::Split test = data::loadSplit(datasetRoot(), "test", /*cap=*/-1);
  data::attachHiddenGoals(test, data::findHiddenFiles(datasetRoot(), "test"));
  EXPECT_TRUE(test.hasGoals);
  EXPECT_TRUE(test.hiddenGoals);
  EXPECT_EQ(test.episodes, hidden.episodes);
  EXPECT_EQ(*test.groundTruth, truth);
}

TEST_F(WorldGeneratorTest, SplitsUseTheRightHouses) {
  std::map<std::string, std::set<std::string>> scenesOf;
  for (const std::string& split : worldSplitNames())
    for (const data::Episode& e :
         data::readEpisodes(data::splitEpisodesPath(datasetRoot(), split))
             .episodes)
      scenesOf[split].insert(data::sceneScanId(e.scene_id));
  const auto& trainHouses = summary_->houses.at("train");
  const std::set<std::string> train(trainHouses.begin(), trainHouses.end());
  for (const char* seen : {"train", "val_seen", "train_aug"})
    for (const auto& house : scenesOf[seen])
      EXPECT_TRUE(train.count(house)) << seen;
  for (const char* unseen : {"val_unseen", "test"})
    for (const auto& house : scenesOf[unseen])
      EXPECT_FALSE(train.count(house)) << unseen;
  for (const auto& house : scenesOf["val_unseen"])
    EXPECT_FALSE(scenesOf["test"].count(house));

  // val_seen trajectories are new: no (start, goal) pair of train
  std::set<std::pair<std::vector<float>, std::vector<float>>> trainPairs;
  auto key = [](const Vec3f& v) {
    return std::vector<float>{v.x(), v.y(), v.z()};
  };
  for (const data::Episode& e :
       data::readEpisodes(data::splitEpisodesPath(datasetRoot(), "train"))
           .episodes)
    trainPairs.insert(
        {key(e.reference_path.front()), key(e.reference_path.back())});
  for (const data::Episode& e :
       data::readEpisodes(data::splitEpisodesPath(datasetRoot(), "val_seen"))
           .episodes)
    EXPECT_FALSE(trainPairs.count(
        {key(e.reference_path.front()), key(e.reference_path.back())}));
}

TEST_F(WorldGeneratorTest, VocabularyAndTokensComeFromTheTrainingCorpus) {
  const auto train =
      data::readEpisodes(data::splitEpisodesPath(datasetRoot(), "train"));
  const auto aug =
      data::readEpisodes(data::splitEpisodesPath(datasetRoot(), "train_aug"));
  const data::Vocabulary& vocab = *train.instruction_vocab;
  EXPECT_EQ(vocab.size(), summary_->vocabulary_size);
  for (const auto* dataset : {&train, &aug}) {
    EXPECT_EQ(*dataset->instruction_vocab, vocab);
    for (const data::Episode& e : dataset->episodes) {
      EXPECT_EQ(e.instruction.instruction_tokens,
                vocab.encode(e.instruction.instruction_text));
      for (const int t : e.instruction.instruction_tokens)
        EXPECT_NE(t, vocab.unkIndex());
    }
  }
  // the two styles differ: speaker instructions are lowercase
  for (const data::Episode& e : aug.episodes)
    EXPECT_EQ(e.instruction.instruction_text.find_first_of(
                  "ABCDEFGHIJKLMNOPQRSTUVWXYZ"),
              std::string::npos);
}

TEST_F(WorldGeneratorTest, GroundTruthReplaysInTheSavedScene) {
  // the scene as any consumer loads it: the .glb and its cached navmesh
  sim::SimConfig simConfig;
  simConfig.navmesh = tinyConfig().navmesh;
  const sim::AgentConfig agent = tinyConfig().agent;
  int replayed = 0;
  for (const char* split : {"train", "val_unseen", "train_aug"}) {
    const auto dataset =
        data::readEpisodes(data::splitEpisodesPath(datasetRoot(), split));
    const data::GroundTruth truth =
        data::readGroundTruth(data::splitGroundTruthPath(datasetRoot(), split));
    std::map<std::string, std::shared_ptr<const sim::Scene>> loaded;
    for (const data::Episode& e : dataset.episodes) {
      auto& scene = loaded[e.scene_id];
      if (!scene) scene = sim::Scene::load(scenes() / e.scene_id, simConfig);
      const data::GroundTruthPath& gt = truth.at(e.episode_id);
      ASSERT_EQ(gt.actions.back(), sim::Action::kStop);
      ASSERT_EQ(gt.locations.size(), static_cast<size_t>(gt.forward_steps) + 1);
      EXPECT_EQ(gt.locations.front(), e.start_position);

      sim::AgentState state{e.start_position, e.startHeading()};
      size_t location = 1;
      size_t next = 1;
      const sim::NavMesh& navmesh = scene->navmesh();
      for (const sim::Action action : gt.actions) {
        const Vec3f before = state.position;
        sim::applyAction(navmesh, agent, state, action);
        if (state.position != before) {
          ASSERT_LT(location, gt.locations.size());
          ASSERT_LT((state.position - gt.locations[location]).norm(), 1e-4f)
              << split << " episode " << e.episode_id << " step " << location;
          ++location;
        }
        while (next < e.reference_path.size() &&
               navmesh.geodesicDistance(state.position,
                                        e.reference_path[next]) <= 0.5f + 1e-3f)
          ++next;
      }
      EXPECT_EQ(location, gt.locations.size());
      EXPECT_EQ(next, e.reference_path.size())
          << split << " episode " << e.episode_id << " missed waypoint "
          << next;
      const float toGoal =
          navmesh.geodesicDistance(state.position, e.goals.front().position);
      EXPECT_LE(toGoal, 0.5f + 1e-3f);
      EXPECT_LE(toGoal, e.goals.front().radius);
      EXPECT_NEAR(
          *e.geodesic_distance,
          navmesh.geodesicDistance(e.start_position, e.goals.front().position),
          1e-3f);
      ++replayed;
    }
  }
  EXPECT_GT(replayed, 20);
}

TEST_F(WorldGeneratorTest, SameSeedGivesByteIdenticalFilesWhateverTheThreads) {
  test::TempDir again;
  WorldOutput output{again.path() / "data", again.path() / "scenes", 1};
  generateWorld(tinyConfig(), output);
  EXPECT_EQ(readTree(datasetRoot()), readTree(again.path() / "data"));
  EXPECT_EQ(readTree(scenes()), readTree(again.path() / "scenes"));

  // another seed is another world
  test::TempDir other;
  WorldConfig config = tinyConfig();
  config.seed = 2;
  generateWorld(config, {other.path() / "data", other.path() / "scenes", 2});
  EXPECT_NE(common::readFile(data::splitEpisodesPath(datasetRoot(), "train")),
            common::readFile(
                data::splitEpisodesPath(other.path() / "data", "train")));
}

TEST_F(WorldGeneratorTest, ExtraTrainHousesAddTrainExtraAndChangeNothingElse) {
  test::TempDir more;
  WorldConfig config = tinyConfig();
  config.splits.extra_train_houses = 2;
  std::ostringstream log;
  const WorldSummary summary = generateWorld(
      config, {more.path() / "data", more.path() / "scenes", 2}, &log);
  EXPECT_THAT(log.str(), HasSubstr("2 extra train"));
  EXPECT_THAT(log.str(), HasSubstr("train_extra: "));

  // every file of the world without extra houses is byte-identical, except
  // the statistics that count the new houses
  auto before = readTree(datasetRoot());
  auto after = readTree(more.path() / "data");
  before.erase("generation_stats.json");
  after.erase("generation_stats.json");
  for (const auto& [name, bytes] : before) {
    ASSERT_TRUE(after.count(name)) << name;
    EXPECT_TRUE(after.at(name) == bytes) << name << " changed";
  }
  for (const auto& [name, bytes] : readTree(scenes()))
    EXPECT_TRUE(readTree(more.path() / "scenes").at(name) == bytes) << name;

  // the new split: train_per_house trajectories in each extra house, their
  // own scenes, tokens of the unchanged vocabulary
  const fs::path root = more.path() / "data";
  const data::EpisodeDataset extra =
      data::readEpisodes(data::splitEpisodesPath(root, "train_extra"));
  const data::GroundTruth truth =
      data::readGroundTruth(data::splitGroundTruthPath(root, "train_extra"));
  ASSERT_EQ(summary.houses.at("train_extra").size(), 2u);
  EXPECT_EQ(summary.trajectories.at("train_extra"),
            2 * config.splits.train_per_house);
  EXPECT_EQ(
      static_cast<int>(extra.episodes.size()),
      2 * config.splits.train_per_house * config.instructions.per_trajectory);
  const data::EpisodeDataset train =
      data::readEpisodes(data::splitEpisodesPath(root, "train"));
  ASSERT_TRUE(extra.instruction_vocab && train.instruction_vocab);
  EXPECT_EQ(*extra.instruction_vocab, *train.instruction_vocab);
  std::set<std::string> trainScenes, extraScenes;
  for (const data::Episode& e : train.episodes) trainScenes.insert(e.scene_id);
  for (const data::Episode& e : extra.episodes) {
    extraScenes.insert(e.scene_id);
    EXPECT_TRUE(truth.count(e.episode_id)) << e.episode_id;
    EXPECT_FALSE(e.goals.empty());
    EXPECT_EQ(e.instruction.instruction_tokens,
              train.instruction_vocab->encode(e.instruction.instruction_text));
    EXPECT_TRUE(fs::exists(more.path() / "scenes" / e.scene_id)) << e.scene_id;
  }
  EXPECT_NO_THROW(data::checkSubInstructions(
      data::readSubInstructions(
          data::splitSubInstructionsPath(root, "train_extra")),
      extra.episodes, "train_extra"));
  EXPECT_EQ(extraScenes.size(), 2u);
  for (const std::string& scene : extraScenes)
    EXPECT_FALSE(trainScenes.count(scene)) << scene;
  const nlohmann::json stats =
      common::readJsonFile(root / "generation_stats.json");
  EXPECT_GE(
      stats.at("splits").at("train_extra").at("unknown_tokens").get<int>(), 0);
}

TEST_F(WorldGeneratorTest, NoExtraHousesNoTrainExtraSplit) {
  EXPECT_FALSE(fs::exists(datasetRoot() / "train_extra"));
  EXPECT_FALSE(summary_->houses.count("train_extra"));
  EXPECT_FALSE(fs::exists(datasetRoot() / "val_unseen_extra"));
  EXPECT_FALSE(summary_->houses.count("val_unseen_extra"));
}

TEST_F(WorldGeneratorTest, ExtraUnseenHousesAreNewHeldOutHousesAndChangeNothingElse) {
  // with extra train houses too: the held-out houses must be neither those
  // nor any house of the first `houses`
  test::TempDir more;
  WorldConfig config = tinyConfig();
  config.splits.extra_train_houses = 1;
  config.splits.extra_unseen_houses = 2;
  std::ostringstream log;
  const WorldSummary summary = generateWorld(
      config, {more.path() / "data", more.path() / "scenes", 2}, &log);
  EXPECT_THAT(log.str(), HasSubstr("2 extra val_unseen"));
  EXPECT_THAT(log.str(), HasSubstr("val_unseen_extra: "));

  // the world without extra houses is unchanged, file for file
  auto before = readTree(datasetRoot());
  auto after = readTree(more.path() / "data");
  before.erase("generation_stats.json");
  for (const auto& [name, bytes] : before) {
    ASSERT_TRUE(after.count(name)) << name;
    EXPECT_TRUE(after.at(name) == bytes) << name << " changed";
  }

  // the new split: val_unseen_per_house trajectories per house, published
  // with goals and ground truth like val_unseen, in houses numbered from
  // kExtraUnseenFirstIndex
  const fs::path root = more.path() / "data";
  const data::EpisodeDataset extra =
      data::readEpisodes(data::splitEpisodesPath(root, "val_unseen_extra"));
  const data::GroundTruth truth = data::readGroundTruth(
      data::splitGroundTruthPath(root, "val_unseen_extra"));
  ASSERT_EQ(summary.houses.at("val_unseen_extra").size(), 2u);
  EXPECT_EQ(summary.trajectories.at("val_unseen_extra"),
            2 * config.splits.val_unseen_per_house);
  const std::set<std::string> expected = {
      worldHouseName(config, kExtraUnseenFirstIndex),
      worldHouseName(config, kExtraUnseenFirstIndex + 1)};
  std::set<std::string> seen;
  for (const data::Episode& e : extra.episodes) {
    seen.insert(fs::path(e.scene_id).parent_path().filename().string());
    EXPECT_TRUE(truth.count(e.episode_id)) << e.episode_id;
    EXPECT_FALSE(e.goals.empty());
    EXPECT_FALSE(e.reference_path.empty());
    EXPECT_TRUE(fs::exists(more.path() / "scenes" / e.scene_id)) << e.scene_id;
  }
  EXPECT_EQ(seen, expected);
  // no house of the world, its extra train house included, is held out twice
  std::set<std::string> others;
  for (int i = 0; i < config.houses + config.splits.extra_train_houses; ++i)
    others.insert(worldHouseName(config, i));
  for (const std::string& house : seen) EXPECT_FALSE(others.count(house)) << house;
  EXPECT_EQ(worldHouseIndex(config, config.houses + 1), kExtraUnseenFirstIndex);
  EXPECT_EQ(worldHouseIndex(config, config.houses), config.houses);
  EXPECT_EQ(worldHouseRoles(config).back(), "val_unseen_extra");
}

TEST_F(WorldGeneratorTest, GeneratedWordsAreRoomToRoomWords) {
  const auto file = test::realR2rSample("val_seen_sample.json.gz");
  if (!fs::exists(file)) GTEST_SKIP() << "no fixture " << file;
  const auto words = common::readJsonFile(file)
                         .at("instruction_vocab")
                         .at("word_list")
                         .get<std::vector<std::string>>();
  const std::set<std::string> r2r(words.begin(), words.end());
  int64_t known = 0, total = 0;
  for (const std::string& split : worldSplitNames())
    for (const data::Episode& e :
         data::readEpisodes(data::splitEpisodesPath(datasetRoot(), split))
             .episodes)
      for (const std::string& token :
           data::tokenize(e.instruction.instruction_text)) {
        ++total;
        known += r2r.count(token) ? 1 : 0;
      }
  ASSERT_GT(total, 500);
  EXPECT_GE(static_cast<double>(known) / static_cast<double>(total), 0.95);
}

// ---------------------------------------------------------------------------
// failures leave no half-written dataset
// ---------------------------------------------------------------------------

TEST(WorldGeneratorFailureTest, UnfillableSplitWritesNothing) {
  test::TempDir dir;
  WorldConfig config = tinyConfig();
  config.trajectories.min_nodes = 60;  // no house has such paths
  config.trajectories.max_nodes = 60;
  try {
    generateWorld(config, {dir.path() / "data", dir.path() / "scenes", 2});
    FAIL() << "expected an error";
  } catch (const std::runtime_error& e) {
    EXPECT_THAT(e.what(), HasSubstr("split 'train'"));
  }
  EXPECT_FALSE(fs::exists(dir.path() / "data" / "train"));
  EXPECT_FALSE(fs::exists(dir.path() / "data" / "embeddings.json.gz"));
}

TEST(WorldGeneratorFailureTest, RegenerationReplacesOldSplitsWhole) {
  test::TempDir dir;
  const fs::path out = dir.path() / "data";
  test::writeText(out / "train" / "stale.txt", "from an older world");
  test::writeText(out / "notes.txt", "kept");
  generateWorld(tinyConfig(), {out, dir.path() / "scenes", 2});
  EXPECT_FALSE(fs::exists(out / "train" / "stale.txt"));
  EXPECT_TRUE(fs::exists(out / "train" / "train.json.gz"));
  EXPECT_TRUE(fs::exists(out / "notes.txt"));
}

TEST(WorldGeneratorConfigTest, DefaultYamlMirrorsTheCode) {
  const auto fromFile = common::loadConfigFile<WorldConfig>(
      test::sourcePath() / "configs" / "world" / "default.yaml");
  // the one difference: the default world adds the 112 train houses whose
  // train_extra split the main job draws from (WorldConfig{} adds none, so
  // that small worlds built from it stay small)
  EXPECT_EQ(fromFile.splits.extra_train_houses, 112);
  WorldConfig code;
  code.splits.extra_train_houses = 112;
  EXPECT_EQ(fromFile, code);
  const WorldConfig tiny = tinyConfig();
  EXPECT_EQ(tiny.houses, 3);
  EXPECT_EQ(tiny.navmesh, WorldConfig{}.navmesh);
}

TEST(WorldGeneratorConfigTest, BadValuesNameTheKey) {
  try {
    common::loadConfigText<WorldConfig>(
        "trajectories:\n  min_nodes: 9\n  max_nodes: 4\n", "world.yaml");
    FAIL() << "expected an error";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("min_nodes"));
  }
  try {
    common::loadConfigText<WorldConfig>("transfer:\n  max_displacment: 0.5\n",
                                        "world.yaml");
    FAIL() << "expected an error";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("transfer.max_displacment"));
  }
  WorldConfig glove;
  glove.glove.threads = 4;
  EXPECT_THROW(glove.validate(), std::invalid_argument);
}

TEST(WorldGeneratorConfigTest, HouseNamesDependOnSeedAndConfig) {
  WorldConfig a;
  WorldConfig b = a;
  b.house.max_rooms = 6;
  WorldConfig c = a;
  c.seed = 9;
  EXPECT_EQ(worldHouseName(a, 3), worldHouseName(a, 3));
  EXPECT_THAT(worldHouseName(a, 3), ::testing::StartsWith("house_003_"));
  EXPECT_NE(worldHouseName(a, 3), worldHouseName(b, 3));
  EXPECT_NE(worldHouseName(a, 3), worldHouseName(c, 3));
}

// The command layer: --houses and --seed override the file, and transfer
// reproduces the generator's node statistics on a written graph and scene.
TEST(WorldCommandsTest, GenerateThenTransferAGeneratedHouse) {
  test::TempDir dir;
  GenerateCommandOptions generate;
  generate.out = dir.path() / "data";
  generate.scenes_dir = dir.path() / "scenes";
  generate.config = kTinyConfig;
  generate.seed = 5;
  generate.threads = 2;
  EXPECT_EQ(loadWorldConfig(generate).seed, 5);
  std::ostringstream out;
  ASSERT_EQ(runGenerateCommand(generate, out), 0);
  EXPECT_THAT(out.str(), HasSubstr("nodes transferred"));

  const auto stats =
      common::readJsonFile(generate.out / "generation_stats.json");
  const auto& perHouse = stats.at("per_house");
  const std::string house = perHouse.begin().key();
  TransferCommandOptions transfer;
  transfer.graph =
      generate.out / "connectivity" / (house + "_connectivity.json");
  transfer.scene = generate.scenes_dir /
                   perHouse.at(house).at("scene_id").get<std::string>();
  transfer.out = dir.path() / "transferred.json";
  transfer.trajectories = 40;
  transfer.json = true;
  std::ostringstream report;
  ASSERT_EQ(runTransferCommand(transfer, report), 0);
  const auto printed = common::parseJson(report.str(), "report");
  const auto& generated = perHouse.at(house).at("transfer");
  for (const char* key : {"nodes", "nodes_valid", "nodes_adjusted"})
    EXPECT_EQ(printed.at(key), generated.at(key)) << key;
  EXPECT_LE(printed.at("trajectories").get<int>(), 40);

  // the written file reads back as a graph of the valid nodes' waypoints
  const data::NavGraph waypoints = data::readNavGraph(transfer.out);
  EXPECT_EQ(waypoints.numNodes(), generated.at("nodes_valid").get<int>());
}

}  // namespace
}  // namespace vln::world
