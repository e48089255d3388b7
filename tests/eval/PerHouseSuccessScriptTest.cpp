// scripts/per_house_success.py: success and SPL per house of a split for
// several agents (each the mean over its result directories) and the paired
// difference of the first two with houses as the unit. Checked here on
// hand-made result files whose per-house means and t interval are worked
// out by hand, and on the inputs it must refuse. Skipped without
// /usr/bin/python3.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <string>
#include <vector>

#include "common/Json.h"
#include "support/ProjectScripts.h"
#include "support/TestPaths.h"

namespace vln::eval {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

int runScript(const std::string& args, std::string* log) {
  return vln::test::runProjectScript("per_house_success.py", args, log);
}

// episodes 1-2 in house_a, 3-4 in house_b, 5-6 in house_c
void writeSplit(const fs::path& data) {
  nlohmann::json episodes = nlohmann::json::array();
  const char* houses[] = {"house_a", "house_a", "house_b",
                          "house_b", "house_c", "house_c"};
  for (int i = 0; i < 6; ++i)
    episodes.push_back({{"episode_id", i + 1},
                        {"scene_id", std::string("procedural/") + houses[i] +
                                         "/" + houses[i] + ".glb"}});
  common::writeJsonFile(data / "val_unseen" / "val_unseen.json.gz",
                        {{"episodes", episodes}});
}

// an eval output folder: episode k succeeded when success[k - 1], SPL half
// of it
void writeRun(const fs::path& dir, const std::vector<int>& success) {
  nlohmann::json episodes = nlohmann::json::array();
  for (size_t i = 0; i < success.size(); ++i)
    episodes.push_back(
        {{"episode_id", std::to_string(i + 1)},
         {"metrics", {{"success", success[i]}, {"spl", 0.5 * success[i]}}}});
  common::writeJsonFile(dir / "episodes_ckpt_3_val_unseen.json.gz",
                        {{"episodes", episodes}});
}

TEST(PerHouseSuccessScriptTest, PerHouseMeansAndTheHouseInterval) {
  if (!vln::test::havePython()) GTEST_SKIP() << "no /usr/bin/python3";
  vln::test::TempDir dir;
  writeSplit(dir / "data");
  writeRun(dir / "a" / "seed0", {1, 0, 1, 1, 0, 0});  // a 0.5, b 1, c 0
  writeRun(dir / "a" / "seed1", {1, 1, 0, 1, 0, 1});  // a 1, b 0.5, c 0.5
  writeRun(dir / "b" / "seed0", {0, 0, 1, 0, 0, 1});  // a 0, b 0.5, c 0.5
  std::string log;
  ASSERT_EQ(runScript("--data " + (dir / "data").string() +
                          " --split val_unseen --agent A '" +
                          (dir / "a" / "seed*").string() + "' --agent B '" +
                          (dir / "b" / "seed*").string() + "'",
                      &log),
            0)
      << log;
  // A over its two runs: 0.75, 0.75, 0.25; B: 0, 0.5, 0.5
  EXPECT_THAT(log, HasSubstr("| house_a | 0.750 / 0.375 | 0.000 / 0.000 |"));
  EXPECT_THAT(log, HasSubstr("| house_b | 0.750 / 0.375 | 0.500 / 0.250 |"));
  EXPECT_THAT(log, HasSubstr("| house_c | 0.250 / 0.125 | 0.500 / 0.250 |"));
  EXPECT_THAT(log, HasSubstr("A (2 runs) | B (1 runs)"));
  // differences 0.75, 0.25, -0.25: mean 0.25, sd 0.5, t(0.975, 2) = 4.303,
  // half-width 4.303 * 0.5 / sqrt(3) = 1.242; SPL all halved
  EXPECT_THAT(log, HasSubstr("A - B SR, houses as the unit (n = 3): +0.250 +/- 1.242"));
  EXPECT_THAT(log, HasSubstr("A - B SPL, houses as the unit (n = 3): +0.125 +/- 0.621"));
}

TEST(PerHouseSuccessScriptTest, InputsItCannotUseAreNamed) {
  if (!vln::test::havePython()) GTEST_SKIP() << "no /usr/bin/python3";
  vln::test::TempDir dir;
  writeSplit(dir / "data");
  writeRun(dir / "a", {1, 0, 1, 1, 0, 0});
  const std::string common =
      "--data " + (dir / "data").string() + " --split val_unseen --agent A ";
  std::string log;
  // no folder matches
  EXPECT_NE(runScript(common + "'" + (dir / "nothing*").string() + "'", &log), 0);
  EXPECT_THAT(log, HasSubstr("no directory matches"));
  // an episode the split does not have
  writeRun(dir / "extra", {1, 0, 1, 1, 0, 0, 1});
  EXPECT_NE(runScript(common + "'" + (dir / "extra").string() + "'", &log), 0);
  EXPECT_THAT(log, HasSubstr("episode 7 is not in split val_unseen"));
  // two checkpoints' files in one folder: which one is meant is unclear
  common::writeJsonFile(dir / "a" / "episodes_ckpt_4_val_unseen.json.gz",
                        {{"episodes", nlohmann::json::array()}});
  EXPECT_NE(runScript(common + "'" + (dir / "a").string() + "'", &log), 0);
  EXPECT_THAT(log, HasSubstr("must hold exactly one"));
  // a split file that is not there
  EXPECT_NE(runScript("--data " + (dir / "nope").string() +
                          " --split val_unseen --agent A '" +
                          (dir / "a").string() + "'",
                      &log),
            0);
  EXPECT_THAT(log, HasSubstr("cannot read"));
}

}  // namespace
}  // namespace vln::eval
