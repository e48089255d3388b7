// loadSplit(): episodes capped evenly over the file, the ground truth read
// only for a split with goals, and an empty split left to the caller; the
// hidden goals of a test split: where they are found, how they are attached
// and the errors naming the file and the episode.

#include "data/Split.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "support/TestPaths.h"
#include "support/TestUtil.h"

namespace vln::data {
namespace {

namespace fs = std::filesystem;

Episode episode(int id, bool withGoal) {
  Episode e;
  e.episode_id = id;
  e.scene_id = "procedural/h/h.glb";
  e.start_position = Vec3f(static_cast<float>(id), 0.0f, 0.0f);
  e.instruction.instruction_text = "walk";
  e.instruction.instruction_tokens = {4, 2};
  if (withGoal) {
    e.goals.push_back({Vec3f(1.0f, 0.0f, 2.0f), 3.0f});
    e.reference_path = {e.start_position, Vec3f(1.0f, 0.0f, 2.0f)};
  }
  return e;
}

void writeSplit(const fs::path& root, const std::string& name, int count,
                bool withGoals, bool withGroundTruth) {
  EpisodeDataset dataset;
  for (int i = 0; i < count; ++i)
    dataset.episodes.push_back(episode(i, withGoals));
  writeEpisodes(splitEpisodesPath(root, name), dataset);
  if (!withGroundTruth) return;
  GroundTruth gt;
  for (int i = 0; i < count; ++i)
    gt[i] = GroundTruthPath{{Vec3f::Zero(), Vec3f(1.0f, 0.0f, 0.0f)},
                            {sim::Action::kMoveForward, sim::Action::kStop},
                            1};
  writeGroundTruth(splitGroundTruthPath(root, name), gt);
}

TEST(SplitTest, CapsEvenlyAndReadsTheGroundTruth) {
  vln::test::TempDir dir;
  writeSplit(dir.path(), "val_unseen", 10, true, true);
  const Split all = loadSplit(dir.path(), "val_unseen", -1);
  EXPECT_EQ(all.name, "val_unseen");
  EXPECT_EQ(all.episodes.size(), 10u);
  EXPECT_TRUE(all.hasGoals);
  ASSERT_NE(all.groundTruth, nullptr);
  EXPECT_EQ(all.groundTruth->size(), 10u);
  const Split few = loadSplit(dir.path(), "val_unseen", 3);
  ASSERT_EQ(few.episodes.size(), 3u);
  std::vector<Episode> expected = all.episodes;
  keepEvenlySpaced(expected, 3);
  for (size_t i = 0; i < 3; ++i)
    EXPECT_EQ(few.episodes[i].episode_id, expected[i].episode_id);
}

TEST(SplitTest, NoGoalsNoGroundTruthNoError) {
  vln::test::TempDir dir;
  writeSplit(dir.path(), "test", 4, false, true);
  const Split test = loadSplit(dir.path(), "test", -1);
  EXPECT_FALSE(test.hasGoals);
  EXPECT_EQ(test.groundTruth, nullptr);  // present on disk, not needed
  writeSplit(dir.path(), "val_seen", 2, true, false);
  EXPECT_EQ(loadSplit(dir.path(), "val_seen", -1).groundTruth, nullptr);
  writeSplit(dir.path(), "empty", 0, true, false);
  EXPECT_TRUE(loadSplit(dir.path(), "empty", -1).episodes.empty());
  EXPECT_THROW(loadSplit(dir.path(), "missing", -1), std::runtime_error);
}

// ---------------------------------------------------------------------------
// hidden goals

using ::testing::HasSubstr;

GroundTruth groundTruthOf(const std::vector<int>& ids) {
  GroundTruth gt;
  for (const int id : ids)
    gt[id] = GroundTruthPath{
        {Vec3f(static_cast<float>(id), 0.0f, 0.0f), Vec3f(1.0f, 0.0f, 2.0f)},
        {sim::Action::kMoveForward, sim::Action::kStop},
        1};
  return gt;
}

// a published test split of `count` episodes without goals, and its hidden
// files under <root>/hidden/test/ covering episodes `hiddenIds`
void writeTestWithHidden(const fs::path& root, int count,
                         const std::vector<int>& hiddenIds) {
  writeSplit(root, "test", count, /*withGoals=*/false,
             /*withGroundTruth=*/false);
  EpisodeDataset hidden;
  for (const int id : hiddenIds) {
    Episode e = episode(id, /*withGoal=*/true);
    e.geodesic_distance = 2.5f;
    hidden.episodes.push_back(e);
  }
  writeEpisodes(hiddenGoalsPath(root, "test"), hidden);
  writeGroundTruth(hiddenGroundTruthPath(root, "test"),
                   groundTruthOf(hiddenIds));
}

TEST(HiddenGoalsTest, AttachedGoalsScoreTheCappedSplit) {
  vln::test::TempDir dir;
  writeTestWithHidden(dir.path(), 6, {0, 1, 2, 3, 4, 5});
  EXPECT_EQ(hiddenGoalsPath(dir.path(), "test"),
            dir.path() / "hidden" / "test" / "test_goals.json.gz");
  EXPECT_EQ(hiddenGroundTruthPath(dir.path(), "test"),
            dir.path() / "hidden" / "test" / "test_gt.json.gz");
  Split test = loadSplit(dir.path(), "test", 3);
  ASSERT_FALSE(test.hasGoals);
  attachHiddenGoals(test, findHiddenFiles(dir.path(), "test"));
  EXPECT_TRUE(test.hasGoals);
  EXPECT_TRUE(test.hiddenGoals);
  ASSERT_EQ(test.episodes.size(), 3u);
  ASSERT_NE(test.groundTruth, nullptr);
  EXPECT_EQ(test.groundTruth->size(), 3u);  // only the kept episodes'
  for (const Episode& e : test.episodes) {
    EXPECT_EQ(e.goals, episode(e.episode_id, true).goals);
    EXPECT_EQ(e.reference_path, episode(e.episode_id, true).reference_path);
    EXPECT_EQ(e.geodesic_distance, 2.5f);
    EXPECT_TRUE(test.groundTruth->contains(e.episode_id));
  }
}

TEST(HiddenGoalsTest, FoundFromEitherFileOrAnyFolderAbove) {
  vln::test::TempDir dir;
  writeTestWithHidden(dir.path(), 2, {0, 1});
  const HiddenSplitFiles expected{hiddenGoalsPath(dir.path(), "test"),
                                  hiddenGroundTruthPath(dir.path(), "test")};
  for (const fs::path& given :
       {dir.path(), dir.path() / "hidden", dir.path() / "hidden" / "test",
        expected.goals, expected.ground_truth}) {
    const HiddenSplitFiles found = findHiddenFiles(given, "test");
    EXPECT_EQ(found.goals, expected.goals) << given;
    EXPECT_EQ(found.ground_truth, expected.ground_truth) << given;
  }
}

TEST(HiddenGoalsTest, MissingFilesAreNamed) {
  vln::test::TempDir dir;
  const fs::path missing = dir / "nowhere";
  EXPECT_THAT(vln::test::errorOf([&] { findHiddenFiles(missing, "test"); }),
              HasSubstr("'" + missing.string() + "' does not exist"));
  // a folder without either file says where it looked
  EXPECT_THAT(vln::test::errorOf([&] { findHiddenFiles(dir.path(), "test"); }),
              HasSubstr("holds no hidden files of split 'test' (looked for "
                        "test_goals.json.gz and test_gt.json.gz in '" +
                        dir.path().string() + "'"));
  // a file of another name
  const fs::path other = vln::test::writeText(dir / "answers.json", "{}");
  EXPECT_THAT(vln::test::errorOf([&] { findHiddenFiles(other, "test"); }),
              HasSubstr("expected test_goals.json.gz or test_gt.json.gz"));
  // one of the two
  writeTestWithHidden(dir.path(), 2, {0, 1});
  fs::remove(hiddenGoalsPath(dir.path(), "test"));
  const std::string error = vln::test::errorOf([&] {
    findHiddenFiles(hiddenGroundTruthPath(dir.path(), "test"), "test");
  });
  EXPECT_THAT(error,
              HasSubstr("'" + hiddenGoalsPath(dir.path(), "test").string() +
                        "' does not exist"));
  EXPECT_THAT(error, HasSubstr("the goals of split 'test'"));
}

TEST(HiddenGoalsTest, FilesThatDoNotCoverTheSplitNameFileAndEpisode) {
  vln::test::TempDir dir;
  const HiddenSplitFiles files{hiddenGoalsPath(dir.path(), "test"),
                               hiddenGroundTruthPath(dir.path(), "test")};
  // episode 3 has no goals in the hidden file
  writeTestWithHidden(dir.path(), 4, {0, 1, 2});
  Split test = loadSplit(dir.path(), "test", -1);
  std::string error =
      vln::test::errorOf([&] { attachHiddenGoals(test, files); });
  EXPECT_THAT(error, HasSubstr(files.goals.string()));
  EXPECT_THAT(error, HasSubstr("episode 3 of split 'test' is missing"));
  EXPECT_FALSE(test.hasGoals);  // nothing changed
  EXPECT_TRUE(test.episodes[0].goals.empty());
  EXPECT_EQ(test.groundTruth, nullptr);

  // episode 2 has no ground truth
  writeTestWithHidden(dir.path(), 3, {0, 1, 2});
  writeGroundTruth(files.ground_truth, groundTruthOf({0, 1}));
  test = loadSplit(dir.path(), "test", -1);
  error = vln::test::errorOf([&] { attachHiddenGoals(test, files); });
  EXPECT_THAT(error, HasSubstr(files.ground_truth.string()));
  EXPECT_THAT(error, HasSubstr("episode 2 of split 'test' is missing"));

  // another world's episode 1
  writeTestWithHidden(dir.path(), 2, {0, 1});
  EpisodeDataset hidden = readEpisodes(files.goals);
  hidden.episodes[1].scene_id = "procedural/other/other.glb";
  writeEpisodes(files.goals, hidden);
  test = loadSplit(dir.path(), "test", -1);
  error = vln::test::errorOf([&] { attachHiddenGoals(test, files); });
  EXPECT_THAT(error, HasSubstr("episode 1 of split 'test' is another "
                               "episode: its scene_id "
                               "'procedural/other/other.glb' differs"));
  hidden.episodes[1] = episode(1, true);
  hidden.episodes[1].instruction.instruction_text = "run";
  writeEpisodes(files.goals, hidden);
  EXPECT_THAT(vln::test::errorOf([&] { attachHiddenGoals(test, files); }),
              HasSubstr("its instruction.instruction_text differs"));

  // an episode without goals in the goals file
  hidden.episodes[1] = episode(1, false);
  writeEpisodes(files.goals, hidden);
  EXPECT_THAT(vln::test::errorOf([&] { attachHiddenGoals(test, files); }),
              HasSubstr("episode 1 of split 'test' has no goals"));
}

TEST(HiddenGoalsTest, MalformedFilesAndScoredSplitsAreErrors) {
  vln::test::TempDir dir;
  const HiddenSplitFiles files{hiddenGoalsPath(dir.path(), "test"),
                               hiddenGroundTruthPath(dir.path(), "test")};
  writeTestWithHidden(dir.path(), 2, {0, 1});
  Split test = loadSplit(dir.path(), "test", -1);
  // the readers' errors name the file (and the episode and field)
  vln::test::writeText(files.ground_truth, R"({"0": {"locations": 3}})");
  EXPECT_THAT(vln::test::errorOf([&] { attachHiddenGoals(test, files); }),
              HasSubstr(files.ground_truth.filename().string()));
  vln::test::writeText(files.goals, "not json");
  EXPECT_THAT(vln::test::errorOf([&] { attachHiddenGoals(test, files); }),
              HasSubstr(files.goals.filename().string()));
  // a split that has goals already
  writeSplit(dir.path(), "val_unseen", 2, true, true);
  Split scored = loadSplit(dir.path(), "val_unseen", -1);
  EXPECT_THAT(vln::test::errorOf([&] { attachHiddenGoals(scored, files); }),
              HasSubstr("split 'val_unseen' already has goals"));
}

}  // namespace
}  // namespace vln::data
