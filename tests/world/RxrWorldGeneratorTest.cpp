#include "world/RxrWorldGenerator.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <map>
#include <memory>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "common/Config.h"
#include "common/FileIo.h"
#include "common/Json.h"
#include "data/Episode.h"
#include "data/GroundTruth.h"
#include "data/RxrEpisodes.h"
#include "data/Split.h"
#include "sim/Agent.h"
#include "sim/Scene.h"
#include "sim/SimConfig.h"
#include "support/TestPaths.h"
#include "world/RxrAnnotations.h"
#include "world/WorldCommands.h"
#include "world/WorldGenerator.h"

namespace vln::world {
namespace {

namespace fs = std::filesystem;

const fs::path kConfigs = test::sourcePath() / "configs";

// The RxR split of configs/world/tiny.yaml's three houses (one train, one
// val_unseen, one test house), with small quotas.
RxrWorldConfig tinyRxrConfig() {
  RxrWorldConfig config =
      common::loadConfigFile<RxrWorldConfig>(kConfigs / "world" / "rxr.yaml");
  config.world =
      common::loadConfigFile<WorldConfig>(kConfigs / "world" / "tiny.yaml");
  config.splits.train_per_house = 8;
  config.splits.val_seen_per_house = 2;
  config.splits.val_unseen_per_house = 4;
  config.splits.test_challenge_per_house = 3;
  return config;
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

data::RxrFilterConfig allRoles() {
  data::RxrFilterConfig filter;
  filter.roles = {"*"};
  return filter;
}

// The tiny R2R world first (its scenes and R2R navmeshes), then its RxR
// split on the same scenes, as a user would run them.
class RxrWorldGeneratorTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new test::TempDir();
    generateWorld(tinyRxrConfig().world, {r2rRoot(), scenes(), 2});
    std::ostringstream log;
    summary_ = new RxrWorldSummary(
        generateRxrWorld(tinyRxrConfig(), {rxrRoot(), scenes(), 2}, &log));
    log_ = new std::string(log.str());
  }
  static void TearDownTestSuite() {
    delete summary_;
    delete log_;
    delete dir_;
  }
  static fs::path r2rRoot() { return dir_->path() / "r2r"; }
  static fs::path rxrRoot() { return dir_->path() / "rxr"; }
  static fs::path scenes() { return dir_->path() / "scenes"; }

  static test::TempDir* dir_;
  static RxrWorldSummary* summary_;
  static std::string* log_;
};

test::TempDir* RxrWorldGeneratorTest::dir_ = nullptr;
RxrWorldSummary* RxrWorldGeneratorTest::summary_ = nullptr;
std::string* RxrWorldGeneratorTest::log_ = nullptr;

TEST_F(RxrWorldGeneratorTest, WritesTheRxrLayoutThatRoundTrips) {
  std::set<int64_t> instructionIds;
  for (const std::string& split : rxrSplitNames()) {
    const bool test = split == "test_challenge";
    for (const char* role : {"guide", "follower"}) {
      SCOPED_TRACE(split + " " + role);
      const fs::path file = data::rxrEpisodesPath(rxrRoot(), split, role);
      ASSERT_TRUE(fs::exists(file));
      EXPECT_EQ(fs::exists(data::rxrGroundTruthPath(rxrRoot(), split, role)),
                !test);
      // episode files round-trip byte for byte through the reader and writer
      const std::vector<data::Episode> episodes =
          data::readRxrEpisodeFile(file);
      EXPECT_EQ(static_cast<int>(episodes.size()),
                summary_->episodes.at(split).at(role));
      ASSERT_FALSE(episodes.empty());
      test::TempDir copy;
      data::EpisodeDataset dataset{episodes, std::nullopt};
      data::writeEpisodes(copy.path() / "copy.json.gz", dataset);
      EXPECT_EQ(common::readFile(file),
                common::readFile(copy.path() / "copy.json.gz"));
      for (const data::Episode& e : episodes) {
        const data::Instruction& i = e.instruction;
        EXPECT_TRUE(i.instruction_tokens.empty());
        ASSERT_TRUE(i.instruction_id.has_value());
        EXPECT_TRUE(instructionIds.insert(*i.instruction_id).second)
            << "instruction id " << *i.instruction_id << " twice";
        EXPECT_THAT(i.language, ::testing::AnyOf("en-US", "en-IN"));
        EXPECT_TRUE(i.annotator_id.has_value());
        EXPECT_EQ(i.edit_distance, 0.0);
        EXPECT_FALSE(i.timed_instruction.empty());
        EXPECT_EQ(e.goals.empty(), test);
        EXPECT_EQ(e.reference_path.empty(), test);
      }
    }
    // both roles together through VLN-CE's reader (ids unique across roles)
    const std::vector<data::Episode> both =
        data::readRxrEpisodes(rxrRoot(), split, allRoles());
    EXPECT_EQ(static_cast<int>(both.size()),
              summary_->episodes.at(split).at("guide") +
                  summary_->episodes.at(split).at("follower"));
    if (!test) {
      const data::GroundTruth truth =
          data::readRxrGroundTruth(rxrRoot(), split, {"guide", "follower"});
      EXPECT_EQ(truth.size(), both.size());
      for (const data::Episode& e : both)
        EXPECT_EQ(truth.count(e.episode_id), 1u);
    }
  }
  // test_challenge's goals and ground truth are hidden
  for (const char* role : {"guide", "follower"}) {
    EXPECT_TRUE(fs::exists(
        data::rxrEpisodesPath(rxrRoot() / "hidden", "test_challenge", role)));
    EXPECT_TRUE(fs::exists(data::rxrGroundTruthPath(rxrRoot() / "hidden",
                                                    "test_challenge", role)));
  }
  // the language filter sees both languages
  data::RxrFilterConfig enIn = allRoles();
  enIn.languages = {"en-IN"};
  const auto indian = data::readRxrEpisodes(rxrRoot(), "train", enIn);
  EXPECT_FALSE(indian.empty());
  EXPECT_LT(indian.size(),
            data::readRxrEpisodes(rxrRoot(), "train", allRoles()).size());
}

TEST_F(RxrWorldGeneratorTest, HiddenTestChallengeScoresThePublishedSplit) {
  // eval --test-ground-truth on an RxR dataset: the published split has no
  // goals; its hidden copy gives them, from any of the folders a user names
  data::DatasetConfig dataset;
  dataset.format = "rxr";
  dataset.data_path = rxrRoot();
  dataset.rxr_filter = allRoles();
  for (const fs::path& given :
       {rxrRoot(), rxrRoot() / "hidden", rxrRoot() / "hidden" / "test_challenge"}) {
    SCOPED_TRACE(given.string());
    data::Split split = data::loadDatasetSplit(dataset, "test_challenge", -1);
    ASSERT_FALSE(split.episodes.empty());
    EXPECT_FALSE(split.hasGoals);
    data::attachHiddenRxrGoals(split, given, dataset.rxr_filter);
    EXPECT_TRUE(split.hasGoals);
    EXPECT_TRUE(split.hiddenGoals);
    ASSERT_TRUE(split.groundTruth);
    EXPECT_EQ(split.groundTruth->size(), split.episodes.size());
    for (const data::Episode& e : split.episodes) {
      EXPECT_FALSE(e.goals.empty()) << e.episode_id;
      EXPECT_FALSE(e.reference_path.empty()) << e.episode_id;
    }
    // a second time is an error: the split has goals now
    EXPECT_THAT([&] { data::attachHiddenRxrGoals(split, given, dataset.rxr_filter); },
                ::testing::ThrowsMessage<std::invalid_argument>(
                    ::testing::HasSubstr("already has goals")));
  }
  // a folder without the hidden files is named with where it was looked
  data::Split split = data::loadDatasetSplit(dataset, "test_challenge", -1);
  EXPECT_THAT([&] { data::attachHiddenRxrGoals(split, rxrRoot() / "train", dataset.rxr_filter); },
              ::testing::ThrowsMessage<std::runtime_error>(::testing::HasSubstr(
                  "holds no hidden RxR files of split 'test_challenge'")));
  // a published split with goals is not a hidden one
  data::Split val = data::loadDatasetSplit(dataset, "val_unseen", -1);
  EXPECT_THROW(data::attachHiddenRxrGoals(val, rxrRoot(), dataset.rxr_filter),
               std::invalid_argument);
}

TEST_F(RxrWorldGeneratorTest, SplitsUseTheWorldsHouses) {
  const std::vector<std::string> roles = worldHouseRoles(tinyRxrConfig().world);
  std::map<std::string, std::string> roleOfScene;
  for (int i = 0; i < static_cast<int>(roles.size()); ++i) {
    const std::string name = worldHouseName(tinyRxrConfig().world, i);
    roleOfScene[strCat("procedural/", name, "/", name, ".glb")] =
        roles[static_cast<size_t>(i)];
  }
  const std::map<std::string, std::string> expected = {
      {"train", "train"},
      {"val_seen", "train"},
      {"val_unseen", "val_unseen"},
      {"test_challenge", "test"}};
  for (const auto& [split, role] : expected)
    for (const data::Episode& e :
         data::readRxrEpisodes(rxrRoot(), split, allRoles()))
      EXPECT_EQ(roleOfScene.at(e.scene_id), role) << split;
}

TEST_F(RxrWorldGeneratorTest, WalksAreLongerThanTheR2RSplitAndNotShortest) {
  // mean nav-graph length over all walks, both datasets' statistics
  const nlohmann::json rxr =
      common::readJsonFile(rxrRoot() / "generation_stats.json");
  const nlohmann::json r2r =
      common::readJsonFile(r2rRoot() / "generation_stats.json");
  const auto meanLength = [](const nlohmann::json& splits) {
    double sum = 0.0, count = 0.0;
    for (const auto& [name, s] : splits.items()) {
      sum += s["mean_graph_path_length"].get<double>() *
             s["trajectories"].get<double>();
      count += s["trajectories"].get<double>();
    }
    return sum / count;
  };
  const double rxrLength = meanLength(rxr["splits"]);
  const double r2rLength = meanLength(r2r["splits"]);
  EXPECT_GT(rxrLength, 1.5 * r2rLength)
      << "RxR " << rxrLength << " m, R2R " << r2rLength << " m";

  // 8-14 nodes; reference paths longer than the start-goal geodesic
  int detours = 0, episodes = 0;
  for (const char* split : {"train", "val_seen", "val_unseen"})
    for (const data::Episode& e :
         data::readRxrEpisodes(rxrRoot(), split, allRoles())) {
      EXPECT_GE(e.reference_path.size(), 8u);
      EXPECT_LE(e.reference_path.size(), 14u);
      double along = 0.0;
      for (size_t i = 1; i < e.reference_path.size(); ++i)
        along += (e.reference_path[i] - e.reference_path[i - 1]).norm();
      detours += along > 1.3 * *e.geodesic_distance ? 1 : 0;
      ++episodes;
    }
  EXPECT_GT(detours, episodes / 2);
}

TEST_F(RxrWorldGeneratorTest, TimingsAreMonotonicAndInsideTheWalk) {
  const RxrInstructionConfig& c = tinyRxrConfig().instructions;
  for (const char* split : {"train", "val_seen", "val_unseen"})
    for (const char* role : {"guide", "follower"}) {
      data::RxrFilterConfig filter;
      filter.roles = {role};
      for (const data::Episode& e :
           data::readRxrEpisodes(rxrRoot(), split, filter)) {
        const double duration =
            walkTimes(
                e.reference_path,
                std::string(role) == "guide" ? c.guide_speed : c.follower_speed,
                c.node_pause)
                .duration();
        const auto& words = e.instruction.timed_instruction;
        double previous = 0.0;
        for (const data::TimedWord& w : words) {
          ASSERT_TRUE(w.start_time && w.end_time);
          EXPECT_FALSE(w.word.empty());
          EXPECT_GE(*w.start_time, previous) << "episode " << e.episode_id;
          EXPECT_LE(*w.start_time, *w.end_time);
          previous = *w.end_time;
        }
        EXPECT_EQ(*words.front().start_time, 0.0);
        EXPECT_LE(*words.back().end_time, duration + 1e-3);
        // the words are the text's
        std::istringstream text(e.instruction.instruction_text);
        size_t tokens = 0;
        for (std::string token; text >> token;) ++tokens;
        EXPECT_LE(words.size(), tokens);
      }
    }
}

TEST_F(RxrWorldGeneratorTest, GroundTruthReplaysToTheGoalInTheRxrTask) {
  // the simulator of configs/rxr/task.yaml: loads the RxR agent's navmesh
  // variant beside each scene (the R2R world wrote "<scene>.navmesh")
  sim::SimConfig sim;
  common::readConfigFileSection(
      kConfigs / "rxr" / "task.yaml", "sim", {},
      [&](common::ConfigVisitor& v) { v.section("sim", sim, "simulator"); });
  const RxrWorldConfig config = tinyRxrConfig();
  EXPECT_EQ(sim.navmesh, config.navmesh);
  EXPECT_EQ(sim.agent.forward_step_size, config.agent.forward_step_size);
  EXPECT_EQ(sim.agent.turn_angle, config.agent.turn_angle);
  EXPECT_EQ(sim.agent.allow_sliding, config.agent.allow_sliding);
  EXPECT_EQ(tinyRxrConfig().world.navmesh.agent_radius, 0.1f);

  int replayed = 0;
  std::map<std::string, std::shared_ptr<const sim::Scene>> loaded;
  for (const char* split : {"train", "val_seen", "val_unseen"}) {
    const auto episodes = data::readRxrEpisodes(rxrRoot(), split, allRoles());
    const data::GroundTruth truth =
        data::readRxrGroundTruth(rxrRoot(), split, {"guide", "follower"});
    for (const data::Episode& e : episodes) {
      auto& scene = loaded[e.scene_id];
      if (!scene) {
        const fs::path file = scenes() / e.scene_id;
        EXPECT_TRUE(fs::exists(sim::navMeshVariantFile(file, sim.navmesh)));
        scene = sim::Scene::load(file, sim);
        ASSERT_NEAR(scene->navmesh().config().agent_radius, 0.18f, 1e-6f);
      }
      const sim::NavMesh& navmesh = scene->navmesh();
      const data::GroundTruthPath& gt = truth.at(e.episode_id);
      sim::EpisodeState state;
      state.agent = {e.start_position, e.startHeading()};
      size_t location = 1;
      for (const sim::Action action : gt.actions) {
        const Vec3f before = state.agent.position;
        sim::stepEpisode(navmesh, sim.agent, sim::TaskConfig{}, state, action);
        if (state.agent.position != before) {
          ASSERT_LT(location, gt.locations.size());
          ASSERT_LT((state.agent.position - gt.locations[location]).norm(),
                    1e-4f)
              << split << " episode " << e.episode_id;
          ++location;
        }
      }
      EXPECT_TRUE(state.called_stop);
      EXPECT_EQ(location, gt.locations.size());
      EXPECT_LE(static_cast<int>(gt.actions.size()), 500);  // step limit
      const float toGoal = navmesh.geodesicDistance(state.agent.position,
                                                    e.goals.front().position);
      EXPECT_LE(toGoal, 0.5f + 1e-3f) << split << " episode " << e.episode_id;
      ++replayed;
    }
  }
  EXPECT_GT(replayed, 20);
}

TEST_F(RxrWorldGeneratorTest, SameSeedGivesByteIdenticalFiles) {
  test::TempDir again;
  generateRxrWorld(tinyRxrConfig(), {again.path() / "rxr", scenes(), 1});
  EXPECT_EQ(readTree(rxrRoot()), readTree(again.path() / "rxr"));

  // another walk seed: the same houses, other walks (the small held-out
  // houses of the tiny world may have none)
  RxrWorldConfig other = tinyRxrConfig();
  other.seed = 2;
  other.splits.val_unseen_per_house = 0;
  other.splits.test_challenge_per_house = 0;
  generateRxrWorld(other, {again.path() / "other", scenes(), 2});
  EXPECT_NE(
      common::readFile(data::rxrEpisodesPath(rxrRoot(), "train", "guide")),
      common::readFile(
          data::rxrEpisodesPath(again.path() / "other", "train", "guide")));
}

TEST_F(RxrWorldGeneratorTest, ReportsTheComparisonWithR2R) {
  EXPECT_THAT(*log_, ::testing::HasSubstr("R2R shortest-path candidates"));
  const nlohmann::json stats =
      common::readJsonFile(rxrRoot() / "generation_stats.json");
  EXPECT_GT(stats["r2r_comparison"]["length_ratio"].get<double>(), 1.5);
  EXPECT_GT(stats["splits"]["train"]["mean_rooms_visited"].get<double>(), 1.0);
  EXPECT_GT(stats["r2r_comparison"]["rxr_mean_rooms_at_nodes"].get<double>(),
            stats["r2r_comparison"]["r2r_mean_candidate_rooms_at_nodes"]
                .get<double>());
}

TEST(RxrWorldConfigTest, RxrYamlMirrorsTheCode) {
  const auto loaded =
      common::loadConfigFile<RxrWorldConfig>(kConfigs / "world" / "rxr.yaml");
  EXPECT_EQ(loaded, RxrWorldConfig{});
  EXPECT_TRUE(isRxrWorldConfigFile(kConfigs / "world" / "rxr.yaml"));
  EXPECT_FALSE(isRxrWorldConfigFile(kConfigs / "world" / "default.yaml"));
  EXPECT_FALSE(isRxrWorldConfigFile(kConfigs / "world" / "tiny.yaml"));
}

TEST(RxrWorldConfigTest, GenerateCommandWritesTheRxrSplit) {
  test::TempDir dir;
  GenerateCommandOptions options;
  options.out = dir.path() / "rxr";
  options.scenes_dir = dir.path() / "scenes";
  options.config = kConfigs / "world" / "rxr.yaml";
  options.houses = 3;
  // tiny.yaml's houses and the fixture's quotas
  options.overrides = {
      "splits.train_per_house=8", "splits.val_seen_per_house=2",
      "splits.val_unseen_per_house=4", "splits.test_challenge_per_house=3"};
  std::ostringstream out;
  ASSERT_EQ(runGenerateCommand(options, out), 0);
  EXPECT_THAT(out.str(), ::testing::HasSubstr("RxR split of 3 houses"));
  EXPECT_TRUE(fs::exists(data::rxrEpisodesPath(options.out, "train", "guide")));
}

}  // namespace
}  // namespace vln::world
