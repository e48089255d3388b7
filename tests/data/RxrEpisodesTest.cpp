// Tests src/data/RxrEpisodes.cpp on fixtures written here in the public
// RxR_VLNCE_v0 layout ({split}/{split}_{role}.json.gz and _gt.json.gz):
// ids as strings, timed_instruction with NaN and missing times (bare NaN
// tokens, as Python's json module writes them), the role, language and
// allowed-episode filters, and the errors.

#include "data/RxrEpisodes.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "common/FileIo.h"
#include "support/TestPaths.h"
#include "support/TestUtil.h"

namespace vln::data {
namespace {

namespace fs = std::filesystem;
using ::testing::AllOf;
using ::testing::ElementsAre;
using ::testing::HasSubstr;
using vln::test::errorOf;

// one episode in the RxR_VLNCE_v0 layout; `extra` is spliced into
// "instruction"
std::string episodeJson(int id, const std::string& language,
                        const std::string& extra = "") {
  const std::string n = std::to_string(id);
  return R"({"episode_id": ")" + n + R"(", "trajectory_id": )" + n +
         R"(, "scene_id": "mp3d/SN83YJsR3w2/SN83YJsR3w2.glb",
  "start_position": [1.0, 0.17, -2.5], "start_rotation": [0, 0.7071068, 0, 0.7071068],
  "info": {"geodesic_distance": 7.25},
  "goals": [{"position": [4.0, 0.17, 1.5], "radius": 3.0}],
  "reference_path": [[1.0, 0.17, -2.5], [2.5, 0.17, 0.0], [4.0, 0.17, 1.5]],
  "instruction": {"instruction_id": ")" +
         std::to_string(1000 + id) +
         R"(", "instruction_text": "Turn around and walk to the sofa.",
    "language": ")" +
         language + R"(", "annotator_id": ")" + std::to_string(7 + id) +
         R"(", "edit_distance": 0.0625,
    "timed_instruction": [{"word": "Turn", "start_time": 0.5, "end_time": 0.9},
      {"word": "around", "start_time": NaN, "end_time": NaN},
      {"word": "and"}, {"word": "walk", "start_time": 1.75, "end_time": 2.0}])" +
         extra + "}}";
}

std::string fileJson(const std::vector<std::string>& episodes) {
  std::string text = "{\"episodes\": [";
  for (size_t i = 0; i < episodes.size(); ++i)
    text += (i ? ",\n" : "\n") + episodes[i];
  return text + "]}";
}

std::string groundTruthJson(const std::vector<int>& ids) {
  std::string text = "{";
  for (size_t i = 0; i < ids.size(); ++i)
    text += (i ? ", \"" : "\"") + std::to_string(ids[i]) +
            R"(": {"locations": [[1.0, 0.17, -2.5], [1.25, 0.17, -2.5]],
                   "actions": [3, 3, 1, 0], "forward_steps": 1})";
  return text + "}";
}

// train: guide episodes 1 (en-US), 2 (hi-IN), 3 (te-IN), 4 (en-IN);
// follower episodes 11 (en-US), 12 (hi-IN)
struct RxrFixture {
  vln::test::TempDir dir;
  RxrFixture() {
    write("guide", {episodeJson(1, "en-US"), episodeJson(2, "hi-IN"),
                    episodeJson(3, "te-IN"), episodeJson(4, "en-IN")});
    write("follower", {episodeJson(11, "en-US"), episodeJson(12, "hi-IN")});
    common::writeFileAtomic(rxrGroundTruthPath(dir.path(), "train", "guide"),
                            groundTruthJson({1, 2, 3, 4}));
    common::writeFileAtomic(rxrGroundTruthPath(dir.path(), "train", "follower"),
                            groundTruthJson({11, 12}));
  }
  void write(const std::string& role, const std::vector<std::string>& eps) {
    common::writeFileAtomic(rxrEpisodesPath(dir.path(), "train", role),
                            fileJson(eps));
  }
  std::vector<int> ids(const RxrFilterConfig& filter) const {
    std::vector<int> out;
    for (const Episode& e : readRxrEpisodes(dir.path(), "train", filter))
      out.push_back(e.episode_id);
    return out;
  }
};

TEST(RxrEpisodesTest, PathsFollowThePublicLayout) {
  EXPECT_EQ(rxrEpisodesPath("RxR_VLNCE_v0", "val_unseen", "guide"),
            fs::path("RxR_VLNCE_v0/val_unseen/val_unseen_guide.json.gz"));
  EXPECT_EQ(rxrGroundTruthPath("RxR_VLNCE_v0", "train", "follower"),
            fs::path("RxR_VLNCE_v0/train/train_follower_gt.json.gz"));
}

TEST(RxrEpisodesTest, ReadsEveryRxrField) {
  RxrFixture f;
  const std::vector<Episode> episodes =
      readRxrEpisodeFile(rxrEpisodesPath(f.dir.path(), "train", "guide"));
  ASSERT_EQ(episodes.size(), 4u);
  const Episode& e = episodes[1];
  EXPECT_EQ(e.episode_id, 2);
  EXPECT_EQ(e.trajectory_id, 2);
  EXPECT_EQ(sceneScanId(e.scene_id), "SN83YJsR3w2");
  EXPECT_FLOAT_EQ(*e.geodesic_distance, 7.25f);
  EXPECT_EQ(e.reference_path.size(), 3u);
  const Instruction& in = e.instruction;
  EXPECT_EQ(in.instruction_id, 1002);
  EXPECT_EQ(in.language, "hi-IN");
  EXPECT_EQ(in.annotator_id, "9");
  EXPECT_DOUBLE_EQ(*in.edit_distance, 0.0625);
  EXPECT_TRUE(in.instruction_tokens.empty());
  ASSERT_EQ(in.timed_instruction.size(), 4u);
  EXPECT_EQ(in.timed_instruction[0], (TimedWord{"Turn", 0.5, 0.9}));
  // NaN and absent times both read as "no time"
  EXPECT_EQ(in.timed_instruction[1],
            (TimedWord{"around", std::nullopt, std::nullopt}));
  EXPECT_EQ(in.timed_instruction[2],
            (TimedWord{"and", std::nullopt, std::nullopt}));
  EXPECT_EQ(in.timed_instruction[3].end_time, 2.0);
}

TEST(RxrEpisodesTest, RoundTripsThroughWriteEpisodes) {
  RxrFixture f;
  const fs::path guide = rxrEpisodesPath(f.dir.path(), "train", "guide");
  EpisodeDataset dataset{readRxrEpisodeFile(guide), std::nullopt};
  const fs::path copy = f.dir / "copy.json.gz";
  writeEpisodes(copy, dataset);
  EXPECT_EQ(readRxrEpisodeFile(copy), dataset.episodes);
  // ids are written as strings, the type VLN-CE declares
  const auto json = episodeToJson(dataset.episodes[0]);
  EXPECT_EQ(json["instruction"]["instruction_id"], "1001");
  EXPECT_EQ(json["instruction"]["annotator_id"], "8");
  EXPECT_FALSE(
      json["instruction"]["timed_instruction"][1].contains("start_time"));
}

TEST(RxrEpisodesTest, FiltersByRoleLanguageAndAllowedEpisodes) {
  RxrFixture f;
  EXPECT_THAT(f.ids({}), ElementsAre(1, 2, 3, 4));  // VLN-CE: guide only
  EXPECT_THAT(f.ids({.roles = {"*"}}), ElementsAre(1, 2, 3, 4, 11, 12));
  EXPECT_THAT(f.ids({.roles = {"follower"}}), ElementsAre(11, 12));
  // rxr_vlnce_english_task.yaml: [en-US, en-IN]
  EXPECT_THAT(
      f.ids({.roles = {"guide", "follower"}, .languages = {"en-US", "en-IN"}}),
      ElementsAre(1, 4, 11));
  EXPECT_THAT(f.ids({.roles = {"*"}, .languages = {"hi-IN"}}),
              ElementsAre(2, 12));
  EXPECT_THAT(f.ids({.roles = {"*"},
                     .languages = {"*"},
                     .episodes_allowed = {"3", "12", "99"}}),
              ElementsAre(3, 12));
}

TEST(RxrEpisodesTest, MergesTheGroundTruthOfTheRoles) {
  RxrFixture f;
  const GroundTruth gt =
      readRxrGroundTruth(f.dir.path(), "train", {"guide", "follower"});
  ASSERT_EQ(gt.size(), 6u);
  EXPECT_EQ(gt.at(12).forward_steps, 1);
  EXPECT_EQ(gt.at(12).actions.size(), 4u);
  EXPECT_EQ(gt.at(12).locations.size(), 2u);
  EXPECT_EQ(readRxrGroundTruth(f.dir.path(), "train", {"guide"}).size(), 4u);

  common::writeFileAtomic(rxrGroundTruthPath(f.dir.path(), "train", "follower"),
                          groundTruthJson({4}));
  EXPECT_THAT(
      errorOf([&] {
        readRxrGroundTruth(f.dir.path(), "train", {"guide", "follower"});
      }),
      AllOf(HasSubstr("train_follower_gt.json.gz"), HasSubstr("episode 4"),
            HasSubstr("earlier role")));
  EXPECT_THAT(
      errorOf([&] { readRxrGroundTruth(f.dir.path(), "train", {"leader"}); }),
      HasSubstr("role 'leader'"));
}

TEST(RxrEpisodesTest, RefusesBadFiltersAndFiles) {
  RxrFixture f;
  EXPECT_THAT(errorOf([&] { f.ids({.roles = {"leader"}}); }),
              HasSubstr("roles: unknown role 'leader'"));
  EXPECT_THAT(errorOf([&] { f.ids({.languages = {"fr-FR"}}); }),
              HasSubstr("unknown language 'fr-FR'"));
  EXPECT_THAT(errorOf([&] { f.ids({.episodes_allowed = {"ep3"}}); }),
              HasSubstr("episodes_allowed: 'ep3'"));
  EXPECT_THAT(errorOf([&] { f.ids({.roles = {}}); }),
              HasSubstr("roles is empty"));

  // an id in both roles' files
  f.write("follower", {episodeJson(2, "en-US")});
  EXPECT_THAT(errorOf([&] { f.ids({.roles = {"*"}}); }),
              AllOf(HasSubstr("train_follower.json.gz"), HasSubstr("episode 2"),
                    HasSubstr("earlier role")));

  // an R2R episode (no instruction_id), a bad id, bad times, a missing file
  const auto fails = [&](const std::string& episode) {
    f.write("guide", {episode});
    return errorOf([&] { f.ids({}); });
  };
  std::string r2r = episodeJson(5, "en-US");
  r2r.replace(r2r.find("\"instruction_id\": \"1005\", "), 26, "");
  EXPECT_THAT(fails(r2r),
              AllOf(HasSubstr("train_guide.json.gz"), HasSubstr("episode 5"),
                    HasSubstr("'instruction.instruction_id' is "
                              "missing")));
  std::string badId = episodeJson(5, "en-US");
  badId.replace(badId.find("\"1005\""), 6, "\"10x5\"");
  EXPECT_THAT(fails(badId), AllOf(HasSubstr("episode 5"),
                                  HasSubstr("instruction.instruction_id"),
                                  HasSubstr("decimal string")));
  EXPECT_THAT(fails(episodeJson(5, "en-US", R"(, "edit_distance": "x")")),
              HasSubstr("'instruction.edit_distance' must be a number"));
  std::string badTime = episodeJson(5, "en-US");
  badTime.replace(badTime.find("\"end_time\": 0.9"), 15, "\"end_time\": \"0\"");
  EXPECT_THAT(fails(badTime), AllOf(HasSubstr("timed_instruction' entry 0"),
                                    HasSubstr("'end_time' must be a number")));
  EXPECT_THAT(errorOf([&] { readRxrEpisodes(f.dir.path(), "val_seen", {}); }),
              HasSubstr("val_seen_guide.json.gz"));
}

TEST(RxrEpisodesTest, NanTokensInsideStringsAreKept) {
  vln::test::TempDir dir;
  std::string episode = episodeJson(1, "en-US");
  episode.replace(episode.find("Turn around"), 11, "NaN Infinity");
  common::writeFileAtomic(dir / "e.json", fileJson({episode}));
  EXPECT_EQ(readRxrEpisodeFile(dir / "e.json")[0].instruction.instruction_text,
            "NaN Infinity and walk to the sofa.");
}

}  // namespace
}  // namespace vln::data
