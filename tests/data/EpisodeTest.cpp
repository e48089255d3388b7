// Tests src/data/Episode.cpp and src/data/GroundTruth.cpp: the R2R_VLNCE
// layouts on hand-made fixtures and on the real val_seen sample.

#include "data/Episode.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <fstream>
#include <functional>

#include "common/FileIo.h"
#include "common/Json.h"
#include "data/GroundTruth.h"
#include "support/TestPaths.h"
#include "support/TestUtil.h"

namespace vln::data {
namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;
using ::testing::ThrowsMessage;

// structural JSON equality with numbers compared to `tolerance`; on a
// difference, `where` receives the JSON pointer of the first one
bool jsonNear(const nlohmann::json& a, const nlohmann::json& b,
              double tolerance, std::string& where,
              const std::string& path = "") {
  if (a.is_number() && b.is_number()) {
    if (std::abs(a.get<double>() - b.get<double>()) <= tolerance) return true;
    where = path + " (" + a.dump() + " vs " + b.dump() + ")";
    return false;
  }
  if (a.type() != b.type()) {
    where = path + " (type " + a.type_name() + " vs " + b.type_name() + ")";
    return false;
  }
  if (a.is_object()) {
    if (a.size() != b.size()) {
      where = path + " (keys " + std::to_string(a.size()) + " vs " +
              std::to_string(b.size()) + ")";
      return false;
    }
    for (const auto& [key, value] : a.items()) {
      if (!b.contains(key)) {
        where = path + "/" + key + " (missing)";
        return false;
      }
      if (!jsonNear(value, b[key], tolerance, where, path + "/" + key))
        return false;
    }
    return true;
  }
  if (a.is_array()) {
    if (a.size() != b.size()) {
      where = path + " (length " + std::to_string(a.size()) + " vs " +
              std::to_string(b.size()) + ")";
      return false;
    }
    for (size_t i = 0; i < a.size(); ++i)
      if (!jsonNear(a[i], b[i], tolerance, where,
                    path + "/" + std::to_string(i)))
        return false;
    return true;
  }
  if (a != b) where = path + " (" + a.dump() + " vs " + b.dump() + ")";
  return a == b;
}

// =========================================================================
// episodes: hand-made fixtures
// =========================================================================

TEST(EpisodeTest, ReadsEveryFieldOfTheFixture) {
  EpisodeDataset dataset = readEpisodes(test::r2rFixture("tiny_split.json"));
  ASSERT_EQ(dataset.episodes.size(), 3u);
  ASSERT_TRUE(dataset.instruction_vocab.has_value());
  EXPECT_EQ(dataset.instruction_vocab->size(), 23);

  const Episode& first = dataset.episodes[0];
  EXPECT_EQ(first.episode_id, 1);
  EXPECT_EQ(first.trajectory_id, 10);
  EXPECT_EQ(first.scene_id, "mp3d/tinyScanA/tinyScanA.glb");
  EXPECT_EQ(first.start_position, Vec3f(1.0f, 0.0f, 2.0f));
  EXPECT_FLOAT_EQ(first.startHeading(), 0.0f);
  ASSERT_TRUE(first.geodesic_distance.has_value());
  EXPECT_FLOAT_EQ(*first.geodesic_distance, 5.0f);
  ASSERT_EQ(first.goals.size(), 1u);
  EXPECT_EQ(first.goals[0].position, Vec3f(4.0f, 0.0f, -2.0f));
  EXPECT_FLOAT_EQ(first.goals[0].radius, 3.0f);
  EXPECT_EQ(first.reference_path.size(), 3u);
  EXPECT_EQ(first.instruction.instruction_text,
            "Walk down the stairs, turn right and stop at the "
            "T-intersection.");
  EXPECT_EQ(first.instruction.instruction_tokens,
            (std::vector<int>{22, 7, 18, 14, 20, 11, 4, 15, 5, 18, 16, 3, 0, 0,
                              0, 0}));

  // episode 7 starts turned 90 degrees left (quaternion [0, sin 45, 0, cos 45])
  const Episode& third = dataset.episodes[2];
  EXPECT_EQ(third.episode_id, 7);
  EXPECT_NEAR(third.startHeading(), kPi / 2.0f, 1e-6f);
}

TEST(EpisodeTest, TestSplitHasNoOptionalFieldsAndWritesNone) {
  test::TempDir dir;
  EpisodeDataset dataset = readEpisodes(test::r2rFixture("test_split.json"));
  ASSERT_EQ(dataset.episodes.size(), 2u);
  EXPECT_FALSE(dataset.instruction_vocab.has_value());
  for (const Episode& episode : dataset.episodes) {
    EXPECT_FALSE(episode.geodesic_distance.has_value());
    EXPECT_TRUE(episode.goals.empty());
    EXPECT_TRUE(episode.reference_path.empty());
    EXPECT_TRUE(episode.instruction.instruction_tokens.empty());
  }
  writeEpisodes(dir / "test.json.gz", dataset);
  nlohmann::json written = common::readJsonFile(dir / "test.json.gz");
  EXPECT_EQ(written, common::readJsonFile(test::r2rFixture("test_split.json")));
  EXPECT_FALSE(written.contains("instruction_vocab"));
  EXPECT_FALSE(written["episodes"][0].contains("goals"));
  EXPECT_FALSE(
      written["episodes"][0]["instruction"].contains("instruction_tokens"));
}

TEST(EpisodeTest, RoundTripsThroughJsonAndGzip) {
  test::TempDir dir;
  EpisodeDataset dataset = readEpisodes(test::r2rFixture("tiny_split.json"));
  for (const char* name : {"out.json", "out.json.gz"}) {
    writeEpisodes(dir / name, dataset);
    EXPECT_EQ(readEpisodes(dir / name), dataset) << name;
  }
  // the .gz name really produces a gzip stream (magic bytes 1f 8b)
  std::ifstream packed(dir / "out.json.gz", std::ios::binary);
  std::array<unsigned char, 2> magic{};
  packed.read(reinterpret_cast<char*>(magic.data()), 2);
  EXPECT_EQ(magic, (std::array<unsigned char, 2>{0x1f, 0x8b}));
  // the written JSON equals the hand-made file value for value (rotations
  // are stored as float32)
  std::string where;
  EXPECT_TRUE(
      jsonNear(common::readJsonFile(dir / "out.json"),
               common::readJsonFile(test::r2rFixture("tiny_split.json")),
               /*tolerance=*/1e-7, where))
      << "first difference at " << where;
}

// =========================================================================
// episodes: error paths name the file, the episode and the field
// =========================================================================

struct BadEpisodeCase {
  std::string name;
  std::function<void(nlohmann::json&)> corrupt;
  std::vector<std::string> expected;  // substrings of the message
};

TEST(EpisodeTest, RejectsMalformedEpisodesNamingFileEpisodeAndField) {
  const nlohmann::json good =
      common::readJsonFile(test::r2rFixture("tiny_split.json"));
  const std::vector<BadEpisodeCase> cases = {
      {"missing field",
       [](nlohmann::json& j) { j["episodes"][1].erase("start_position"); },
       {"episode 2", "field 'start_position' is missing"}},
      {"string id",
       [](nlohmann::json& j) { j["episodes"][1]["episode_id"] = "two"; },
       {"episode index 1", "'episode_id' must be an integer"}},
      {"fractional id",
       [](nlohmann::json& j) { j["episodes"][1]["episode_id"] = 2.5; },
       {"episode index 1", "'episode_id' must be an integer"}},
      {"scene id not a string",
       [](nlohmann::json& j) { j["episodes"][2]["scene_id"] = 7; },
       {"episode 7", "'scene_id' must be a string"}},
      {"tilted rotation",
       [](nlohmann::json& j) {
         j["episodes"][1]["start_rotation"] = {0.1, 0.7, 0.0, 0.7};
       },
       {"episode 2", "'start_rotation' is not a unit yaw-only quaternion"}},
      {"non-unit rotation",
       [](nlohmann::json& j) {
         j["episodes"][1]["start_rotation"] = {0.0, 0.5, 0.0, 0.5};
       },
       {"episode 2", "'start_rotation' is not a unit yaw-only quaternion"}},
      {"short rotation",
       [](nlohmann::json& j) {
         j["episodes"][1]["start_rotation"] = {0.0, 1.0, 0.0};
       },
       {"episode 2", "'start_rotation' must be an [x, y, z, w] array"}},
      {"token beyond vocab",
       [](nlohmann::json& j) {
         j["episodes"][2]["instruction"]["instruction_tokens"][3] = 23;
       },
       {"episode 7", "'instruction.instruction_tokens' entry 3 is 23",
        "[0, 23)"}},
      {"negative token",
       [](nlohmann::json& j) {
         j["episodes"][0]["instruction"]["instruction_tokens"][0] = -1;
       },
       {"episode 1", "'instruction.instruction_tokens' entry 0 is -1"}},
      {"fractional token",
       [](nlohmann::json& j) {
         j["episodes"][0]["instruction"]["instruction_tokens"][1] = 1.5;
       },
       {"episode 1", "instruction_tokens' entry 1 must be an integer"}},
      {"missing instruction text",
       [](nlohmann::json& j) {
         j["episodes"][0]["instruction"].erase("instruction_text");
       },
       {"episode 1", "field 'instruction_text' is missing"}},
      {"path point of two values",
       [](nlohmann::json& j) {
         j["episodes"][0]["reference_path"][1] = {1.0, 2.0};
       },
       {"episode 1", "'reference_path' entry 1 must be an [x, y, z] array"}},
      {"position of strings",
       [](nlohmann::json& j) {
         j["episodes"][0]["start_position"] = {"1", "0", "2"};
       },
       {"episode 1", "'start_position' must be a number"}},
      {"zero goal radius",
       [](nlohmann::json& j) { j["episodes"][0]["goals"][0]["radius"] = 0.0; },
       {"episode 1", "'goals[0].radius' must be > 0"}},
      {"negative geodesic distance",
       [](nlohmann::json& j) {
         j["episodes"][0]["info"]["geodesic_distance"] = -1.0;
       },
       {"episode 1", "'info.geodesic_distance'"}},
      {"duplicate id",
       [](nlohmann::json& j) { j["episodes"][2]["episode_id"] = 1; },
       {"episode 1", "'episode_id' is duplicated (episode index 2)"}},
      {"episodes not a list",
       [](nlohmann::json& j) {
         j["episodes"] = {{"a", 1}};
       },
       {"field 'episodes' must be an array"}},
      {"no episodes",
       [](nlohmann::json& j) { j.erase("episodes"); },
       {"field 'episodes' is missing"}},
      {"num_vocab disagrees",
       [](nlohmann::json& j) { j["instruction_vocab"]["num_vocab"] = 22; },
       {"instruction_vocab", "'num_vocab' is 22"}},
      {"stoi disagrees",
       [](nlohmann::json& j) { j["instruction_vocab"]["stoi"]["walk"] = 3; },
       {"instruction_vocab", "'stoi' maps 'walk' to 3"}},
  };
  test::TempDir dir;
  for (const BadEpisodeCase& c : cases) {
    SCOPED_TRACE(c.name);
    nlohmann::json bad = good;
    c.corrupt(bad);
    auto file = dir / "bad_split.json.gz";
    common::writeJsonFile(file, bad);
    try {
      readEpisodes(file);
      ADD_FAILURE() << "no exception";
    } catch (const std::invalid_argument& e) {
      EXPECT_THAT(e.what(), HasSubstr("bad_split.json.gz"));
      for (const std::string& part : c.expected)
        EXPECT_THAT(e.what(), HasSubstr(part));
    }
  }
}

TEST(EpisodeTest, MalformedAndTruncatedFilesNameTheFile) {
  test::TempDir dir;
  test::writeText(dir / "broken.json", "{\"episodes\": [{\"episode_id\": 1,");
  EXPECT_THAT([&] { readEpisodes(dir / "broken.json"); },
              ThrowsMessage<std::invalid_argument>(
                  AllOf(HasSubstr("broken.json"), HasSubstr("malformed"))));

  std::string packed = common::gzipCompress(
      common::readFile(test::r2rFixture("tiny_split.json")));
  test::writeText(dir / "cut.json.gz", packed.substr(0, packed.size() / 2));
  EXPECT_THAT([&] { readEpisodes(dir / "cut.json.gz"); },
              ThrowsMessage<std::runtime_error>(
                  AllOf(HasSubstr("cut.json.gz"), HasSubstr("truncated"))));
  EXPECT_THAT([&] { readEpisodes(dir / "absent.json.gz"); },
              ThrowsMessage<std::runtime_error>(HasSubstr("absent.json.gz")));
}

TEST(EpisodeTest, WriterRejectsInvalidEpisodesWithoutTouchingTheDisk) {
  test::TempDir dir;
  EpisodeDataset dataset = readEpisodes(test::r2rFixture("tiny_split.json"));
  auto file = dir / "split.json.gz";
  writeEpisodes(file, dataset);
  const std::string before = common::readFile(file);

  EpisodeDataset tilted = dataset;
  tilted.episodes[1].start_rotation = {0.3f, 0.0f, 0.0f, 0.954f};
  EXPECT_THAT([&] { writeEpisodes(file, tilted); },
              ThrowsMessage<std::invalid_argument>(
                  AllOf(HasSubstr("split.json.gz"), HasSubstr("episode 2"),
                        HasSubstr("start_rotation"))));
  EpisodeDataset outOfVocab = dataset;
  outOfVocab.episodes[0].instruction.instruction_tokens[0] = 500;
  EXPECT_THAT([&] { writeEpisodes(file, outOfVocab); },
              ThrowsMessage<std::invalid_argument>(
                  HasSubstr("instruction_tokens' entry 0 is 500")));
  EpisodeDataset nanPath = dataset;
  nanPath.episodes[2].reference_path[1].y() = std::nanf("");
  EXPECT_THAT(
      [&] { writeEpisodes(file, nanPath); },
      ThrowsMessage<std::invalid_argument>(AllOf(
          HasSubstr("episode 7"), HasSubstr("'reference_path' entry 1"))));
  EXPECT_THAT([&] { writeEpisodes(dir / "new.json", nanPath); },
              ThrowsMessage<std::invalid_argument>(HasSubstr("new.json")));

  // the previous file is intact and no half-written file appeared
  EXPECT_EQ(common::readFile(file), before);
  EXPECT_FALSE(std::filesystem::exists(dir / "new.json"));
  EXPECT_EQ(test::countEntries(dir.path()), 1);
}

// =========================================================================
// scene paths
// =========================================================================

TEST(EpisodeTest, ResolvesScenesUnderTheScenesDirectory) {
  test::TempDir dir;
  auto scenes = dir / "scene_datasets";
  auto glb =
      test::writeText(scenes / "mp3d" / "tinyScanA" / "tinyScanA.glb", "glTF");
  EXPECT_EQ(resolveScenePath(scenes, "mp3d/tinyScanA/tinyScanA.glb"), glb);
  EXPECT_EQ(resolveScenePath("/unused", glb.string()), glb);
  EXPECT_EQ(sceneScanId("mp3d/tinyScanA/tinyScanA.glb"), "tinyScanA");
  EXPECT_THAT(
      [&] { resolveScenePath(scenes, "mp3d/missingScan/missingScan.glb"); },
      ThrowsMessage<std::runtime_error>(
          AllOf(HasSubstr("mp3d/missingScan/missingScan.glb"),
                HasSubstr("scene_datasets"), HasSubstr("does not exist"))));
  EXPECT_EQ(splitEpisodesPath("data/R2R", "val_seen"),
            std::filesystem::path("data/R2R/val_seen/val_seen.json.gz"));
  EXPECT_EQ(splitGroundTruthPath("data/R2R", "val_seen"),
            std::filesystem::path("data/R2R/val_seen/val_seen_gt.json.gz"));
}

// =========================================================================
// episodes: the real val_seen sample
// =========================================================================

TEST(EpisodeTest, RealSampleMatchesTheRawJson) {
  auto file = test::realR2rSample("val_seen_sample.json.gz");
  if (!std::filesystem::exists(file)) GTEST_SKIP() << "no " << file;
  EpisodeDataset dataset = readEpisodes(file);
  nlohmann::json raw = common::readJsonFile(file);
  ASSERT_EQ(dataset.episodes.size(), raw["episodes"].size());
  ASSERT_EQ(dataset.episodes.size(), 12u);
  ASSERT_TRUE(dataset.instruction_vocab.has_value());
  EXPECT_EQ(dataset.instruction_vocab->size(),
            raw["instruction_vocab"]["num_vocab"].get<int>());
  for (size_t i = 0; i < dataset.episodes.size(); ++i) {
    const Episode& episode = dataset.episodes[i];
    const nlohmann::json& expected = raw["episodes"][i];
    EXPECT_EQ(episode.episode_id, expected["episode_id"].get<int>());
    EXPECT_EQ(episode.scene_id, expected["scene_id"].get<std::string>());
    EXPECT_EQ(episode.reference_path.size(), expected["reference_path"].size());
    EXPECT_FLOAT_EQ(*episode.geodesic_distance,
                    expected["info"]["geodesic_distance"].get<float>());
    EXPECT_EQ(episode.instruction.instruction_tokens.size(), 200u);
    // the goal is the last reference path node in R2R_VLNCE
    EXPECT_EQ(episode.goals.at(0).position, episode.reference_path.back());
    EXPECT_EQ(episode.start_position, episode.reference_path.front());
  }
  // first episode: values read off the file
  EXPECT_EQ(dataset.episodes[0].trajectory_id, 37);
  EXPECT_EQ(sceneScanId(dataset.episodes[0].scene_id), "s8pcmisQ38h");
}

TEST(EpisodeTest, RealSampleRoundTripsToTheSameJsonValues) {
  auto file = test::realR2rSample("val_seen_sample.json.gz");
  if (!std::filesystem::exists(file)) GTEST_SKIP() << "no " << file;
  test::TempDir dir;
  writeEpisodes(dir / "val_seen.json.gz", readEpisodes(file));
  std::string where;
  EXPECT_TRUE(jsonNear(common::readJsonFile(file),
                       common::readJsonFile(dir / "val_seen.json.gz"),
                       /*tolerance=*/1e-6, where))
      << "first difference at " << where;
}

// =========================================================================
// ground truth
// =========================================================================

TEST(EpisodeTest, GroundTruthFixtureRoundTrips) {
  test::TempDir dir;
  GroundTruth groundTruth =
      readGroundTruth(test::r2rFixture("tiny_split_gt.json"));
  ASSERT_EQ(groundTruth.size(), 3u);
  const GroundTruthPath& first = groundTruth.at(1);
  EXPECT_EQ(first.forward_steps, 2);
  EXPECT_EQ(first.locations.size(), 3u);
  EXPECT_EQ(first.locations[2], Vec3f(1.0f, 0.0f, 1.5f));
  using sim::Action;
  EXPECT_EQ(first.actions,
            (std::vector<Action>{Action::kMoveForward, Action::kMoveForward,
                                 Action::kTurnRight, Action::kTurnRight,
                                 Action::kTurnRight, Action::kTurnLeft,
                                 Action::kStop}));
  writeGroundTruth(dir / "gt.json.gz", groundTruth);
  EXPECT_EQ(readGroundTruth(dir / "gt.json.gz"), groundTruth);
  EXPECT_EQ(common::readJsonFile(dir / "gt.json.gz"),
            common::readJsonFile(test::r2rFixture("tiny_split_gt.json")));
}

TEST(EpisodeTest, GroundTruthErrorsNameFileEpisodeAndField) {
  const nlohmann::json good =
      common::readJsonFile(test::r2rFixture("tiny_split_gt.json"));
  const std::vector<BadEpisodeCase> cases = {
      {"action out of range",
       [](nlohmann::json& j) { j["2"]["actions"][1] = 4; },
       {"episode 2", "'actions' entry 1 is 4"}},
      {"action not an integer",
       [](nlohmann::json& j) { j["2"]["actions"][0] = "LEFT"; },
       {"episode 2", "'actions' entry 0 must be an integer"}},
      {"missing locations",
       [](nlohmann::json& j) { j["7"].erase("locations"); },
       {"episode 7", "field 'locations' is missing"}},
      {"bad location",
       [](nlohmann::json& j) { j["1"]["locations"][0] = {1.0}; },
       {"episode 1", "'locations' entry 0 must be an [x, y, z] array"}},
      {"fractional forward steps",
       [](nlohmann::json& j) { j["1"]["forward_steps"] = 2.5; },
       {"episode 1", "'forward_steps' must be an integer"}},
      {"negative forward steps",
       [](nlohmann::json& j) { j["1"]["forward_steps"] = -2; },
       {"episode 1", "'forward_steps' must be >= 0"}},
      {"key not an id",
       [](nlohmann::json& j) { j["seven"] = j["7"]; },
       {"key 'seven' is not an integer episode id"}},
  };
  test::TempDir dir;
  for (const BadEpisodeCase& c : cases) {
    SCOPED_TRACE(c.name);
    nlohmann::json bad = good;
    c.corrupt(bad);
    common::writeJsonFile(dir / "bad_gt.json.gz", bad);
    try {
      readGroundTruth(dir / "bad_gt.json.gz");
      ADD_FAILURE() << "no exception";
    } catch (const std::invalid_argument& e) {
      EXPECT_THAT(e.what(), HasSubstr("bad_gt.json.gz"));
      for (const std::string& part : c.expected)
        EXPECT_THAT(e.what(), HasSubstr(part));
    }
  }
  std::string packed = common::gzipCompress(
      common::readFile(test::r2rFixture("tiny_split_gt.json")));
  test::writeText(dir / "cut_gt.json.gz", packed.substr(0, packed.size() - 9));
  EXPECT_THAT([&] { readGroundTruth(dir / "cut_gt.json.gz"); },
              ThrowsMessage<std::runtime_error>(HasSubstr("cut_gt.json.gz")));
}

TEST(EpisodeTest, RealGroundTruthMatchesRawJsonAndRoundTrips) {
  auto file = test::realR2rSample("val_seen_sample_gt.json.gz");
  if (!std::filesystem::exists(file)) GTEST_SKIP() << "no " << file;
  GroundTruth groundTruth = readGroundTruth(file);
  nlohmann::json raw = common::readJsonFile(file);
  ASSERT_EQ(groundTruth.size(), raw.size());
  for (const auto& [key, entry] : raw.items()) {
    const GroundTruthPath& path = groundTruth.at(std::stoi(key));
    EXPECT_EQ(path.actions.size(), entry["actions"].size());
    EXPECT_EQ(path.locations.size(), entry["locations"].size());
    EXPECT_EQ(path.forward_steps, entry["forward_steps"].get<int>());
    // the documented layout: locations = start + one per MOVE_FORWARD,
    // ending with STOP
    EXPECT_EQ(path.locations.size(),
              static_cast<size_t>(path.forward_steps) + 1);
    EXPECT_EQ(path.actions.back(), sim::Action::kStop);
  }
  test::TempDir dir;
  writeGroundTruth(dir / "gt.json.gz", groundTruth);
  std::string where;
  EXPECT_TRUE(jsonNear(raw, common::readJsonFile(dir / "gt.json.gz"),
                       /*tolerance=*/1e-6, where))
      << "first difference at " << where;
}

}  // namespace

TEST(KeepEvenlySpacedTest, SpreadsOverTheListInFileOrder) {
  auto ids = [](const std::vector<Episode>& episodes) {
    std::vector<int64_t> out;
    for (const auto& e : episodes) out.push_back(e.episode_id);
    return out;
  };
  std::vector<Episode> ten(10);
  for (int i = 0; i < 10; ++i) ten[static_cast<size_t>(i)].episode_id = i;

  auto some = ten;
  keepEvenlySpaced(some, 4);
  EXPECT_EQ(ids(some), (std::vector<int64_t>{0, 2, 5, 7}));
  some = ten;
  keepEvenlySpaced(some, 1);
  EXPECT_EQ(ids(some), (std::vector<int64_t>{0}));
  some = ten;
  keepEvenlySpaced(some, 0);
  EXPECT_TRUE(some.empty());
  for (int all : {-1, 10, 11}) {
    some = ten;
    keepEvenlySpaced(some, all);
    EXPECT_EQ(ids(some), ids(ten)) << all;
  }
}

}  // namespace vln::data
