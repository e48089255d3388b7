// Tests src/data/DatasetStats.cpp and the `stats` command of
// src/data/DataCommands.cpp on hand-made fixtures (values worked out by
// hand) and on the real val_seen sample (values recomputed here from the raw
// JSON, independently of the episode reader).

#include "data/DatasetStats.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <set>
#include <sstream>

#include "common/Json.h"
#include "data/DataCommands.h"
#include "support/TestPaths.h"

namespace vln::data {
namespace {

using ::testing::AllOf;
using ::testing::ElementsAre;
using ::testing::HasSubstr;

TEST(DatasetStatsTest, FixtureValuesWorkedOutByHand) {
  EpisodeDataset dataset = readEpisodes(test::r2rFixture("tiny_split.json"));
  GroundTruth groundTruth =
      readGroundTruth(test::r2rFixture("tiny_split_gt.json"));
  DatasetStats stats = computeDatasetStats(dataset, &groundTruth);
  EXPECT_EQ(stats.episodes, 3);
  EXPECT_EQ(stats.scenes, 2);
  EXPECT_EQ(stats.trajectories, 2);
  EXPECT_EQ(stats.vocabulary_size, 23);
  // 12, 13 and 9 tokens before the padding
  EXPECT_DOUBLE_EQ(stats.mean_instruction_length, 34.0 / 3.0);
  EXPECT_EQ(stats.max_instruction_length, 13);
  // 4 + 3 m twice, and 2.5 + sqrt(5) m for episode 7
  EXPECT_NEAR(stats.mean_path_length, (14.0 + 2.5 + std::sqrt(5.0)) / 3.0,
              1e-6);
  EXPECT_EQ(stats.episodes_with_path, 3);
  EXPECT_NEAR(stats.mean_geodesic_distance, 12.5 / 3.0, 1e-6);
  // 7, 3 and 1 actions
  EXPECT_TRUE(stats.has_ground_truth);
  EXPECT_EQ(stats.ground_truth_matched, 3);
  EXPECT_EQ(stats.ground_truth_missing, 0);
  EXPECT_DOUBLE_EQ(stats.mean_ground_truth_actions, 11.0 / 3.0);
  EXPECT_THAT(stats.action_counts, ElementsAre(3, 3, 2, 3));
}

TEST(DatasetStatsTest, MissingGroundTruthAndTestSplit) {
  EpisodeDataset dataset = readEpisodes(test::r2rFixture("tiny_split.json"));
  GroundTruth partial = readGroundTruth(test::r2rFixture("tiny_split_gt.json"));
  partial.erase(7);
  DatasetStats stats = computeDatasetStats(dataset, &partial);
  EXPECT_EQ(stats.ground_truth_matched, 2);
  EXPECT_EQ(stats.ground_truth_missing, 1);
  EXPECT_DOUBLE_EQ(stats.mean_ground_truth_actions, 5.0);
  EXPECT_THAT(stats.action_counts, ElementsAre(2, 3, 2, 3));

  // the test split has no tokens: lengths come from the tokenizer
  DatasetStats test =
      computeDatasetStats(readEpisodes(test::r2rFixture("test_split.json")));
  EXPECT_EQ(test.episodes, 2);
  EXPECT_EQ(test.vocabulary_size, 0);
  EXPECT_DOUBLE_EQ(test.mean_instruction_length, 12.5);
  EXPECT_EQ(test.episodes_with_path, 0);
  EXPECT_EQ(test.mean_path_length, 0.0);
  EXPECT_FALSE(test.has_ground_truth);
  std::string text = formatDatasetStats(test);
  EXPECT_THAT(text, AllOf(HasSubstr("no reference paths"),
                          HasSubstr("vocabulary size:"), HasSubstr("none")));
  EXPECT_THAT(text, ::testing::Not(HasSubstr("MOVE_FORWARD")));
}

TEST(DatasetStatsTest, RealSampleMatchesIndependentComputation) {
  auto episodesFile = test::realR2rSample("val_seen_sample.json.gz");
  auto gtFile = test::realR2rSample("val_seen_sample_gt.json.gz");
  if (!std::filesystem::exists(episodesFile) ||
      !std::filesystem::exists(gtFile))
    GTEST_SKIP() << "no real samples";
  EpisodeDataset dataset = readEpisodes(episodesFile);
  GroundTruth groundTruth = readGroundTruth(gtFile);
  DatasetStats stats = computeDatasetStats(dataset, &groundTruth);

  // recompute every number from the raw JSON
  nlohmann::json raw = common::readJsonFile(episodesFile);
  nlohmann::json rawGt = common::readJsonFile(gtFile);
  std::set<std::string> scenes;
  double tokens = 0.0;
  double path = 0.0;
  double actions = 0.0;
  std::array<int64_t, 4> counts{};
  for (const auto& episode : raw["episodes"]) {
    scenes.insert(episode["scene_id"].get<std::string>());
    for (int token : episode["instruction"]["instruction_tokens"])
      tokens += token != 0 ? 1.0 : 0.0;
    const auto& points = episode["reference_path"];
    for (size_t i = 1; i < points.size(); ++i) {
      double squared = 0.0;
      for (int k = 0; k < 3; ++k) {
        double d = points[i][k].get<double>() - points[i - 1][k].get<double>();
        squared += d * d;
      }
      path += std::sqrt(squared);
    }
    const auto& gt = rawGt[std::to_string(episode["episode_id"].get<int>())];
    actions += static_cast<double>(gt["actions"].size());
    for (int action : gt["actions"]) ++counts[static_cast<size_t>(action)];
  }
  const double n = static_cast<double>(raw["episodes"].size());
  EXPECT_EQ(stats.episodes, 12);
  EXPECT_EQ(stats.scenes, static_cast<int64_t>(scenes.size()));
  EXPECT_EQ(stats.vocabulary_size, 2504);
  EXPECT_NEAR(stats.mean_instruction_length, tokens / n, 1e-9);
  EXPECT_NEAR(stats.mean_path_length, path / n, 1e-5);
  EXPECT_NEAR(stats.mean_ground_truth_actions, actions / n, 1e-9);
  EXPECT_EQ(stats.action_counts, counts);
  EXPECT_EQ(stats.ground_truth_missing, 0);
}

TEST(DatasetStatsTest, StatsCommandPrintsTextAndJson) {
  StatsCommandOptions options;
  options.episodes = test::r2rFixture("tiny_split.json");
  options.ground_truth = test::r2rFixture("tiny_split_gt.json");
  std::ostringstream text;
  EXPECT_EQ(runStatsCommand(options, text), 0);
  EXPECT_THAT(text.str(),
              AllOf(HasSubstr("tiny_split.json"), HasSubstr("episodes:"),
                    HasSubstr("11.33 tokens (max 13)"),
                    HasSubstr("6.245 m over 3 episodes"),
                    HasSubstr("MOVE_FORWARD:"), HasSubstr("3 (27.3%)")));

  options.json = true;
  std::ostringstream json;
  EXPECT_EQ(runStatsCommand(options, json), 0);
  nlohmann::json parsed = common::parseJson(json.str(), "stats output");
  GroundTruth groundTruth = readGroundTruth(options.ground_truth);
  DatasetStats stats =
      computeDatasetStats(readEpisodes(options.episodes), &groundTruth);
  EXPECT_EQ(parsed, datasetStatsToJson(stats));
  EXPECT_EQ(parsed["action_counts"]["TURN_LEFT"], 2);
}

// The binary end to end (a build dependency of this test).
TEST(DatasetStatsTest, BinaryRunsStatsAndReportsBadInput) {
  auto binary = test::binaryPath() / "bin" / "vlnce-data";
  ASSERT_TRUE(std::filesystem::exists(binary)) << "no " << binary;
  std::string output;
  int status = test::runCommand(
      binary.string() + " --log-level warn stats --episodes " +
          test::r2rFixture("tiny_split.json").string() + " --gt " +
          test::r2rFixture("tiny_split_gt.json").string(),
      &output);
  EXPECT_EQ(status, 0) << output;
  EXPECT_THAT(output, HasSubstr("mean ground-truth actions:   3.67"));

  test::TempDir dir;
  auto bad = test::writeText(dir / "bad.json", "{\"episodes\": [{}]}");
  status = test::runCommand(
      binary.string() + " stats --episodes " + bad.string(), &output);
  EXPECT_EQ(status, 1);
  EXPECT_THAT(output,
              AllOf(HasSubstr("vlnce-data: error:"), HasSubstr("bad.json"),
                    HasSubstr("field 'episode_id' is missing")));
}

}  // namespace
}  // namespace vln::data
