// loadSplit(): episodes capped evenly over the file, the ground truth read
// only for a split with goals, and an empty split left to the caller.

#include "data/Split.h"

#include <gtest/gtest.h>

#include "support/TestPaths.h"

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

}  // namespace
}  // namespace vln::data
