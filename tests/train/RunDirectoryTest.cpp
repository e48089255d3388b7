// Tests of src/train/RunDirectory.cpp: flattening and diffing configs, the
// fresh-run and resume rules, the run directory's lock.

#include "train/RunDirectory.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include "common/FileIo.h"
#include "support/TestPaths.h"

namespace vln::train {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;

TEST(RunDirectoryTest, FlattenNamesEveryKeyPath) {
  ExperimentConfig c;
  const auto flat = flattenConfig(c);
  auto find = [&](const std::string& key) -> std::string {
    for (const auto& [k, v] : flat)
      if (k == key) return v;
    return "<missing>";
  };
  EXPECT_EQ(find("trainer.lr"), "0.00025");
  EXPECT_EQ(find("sim.rgb.width"), "224");
  EXPECT_EQ(find("sim.depth.max_depth"), "10");
  EXPECT_EQ(find("model.policy"), "cma");
  EXPECT_EQ(find("eval.splits"), "['val_seen', 'val_unseen']");
}

TEST(RunDirectoryTest, DifferencesListChangedKeys) {
  ExperimentConfig a, b;
  EXPECT_TRUE(configDifferences(a, b).empty());
  b.trainer.lr = 1e-3;
  b.output.log_level = "debug";
  EXPECT_EQ(configDifferences(a, b),
            (std::vector<std::string>{"trainer.lr", "output.log_level"}));
  EXPECT_EQ(overriddenKeys({"trainer.lr=0.1", "eval.splits=[a]"}),
            (std::vector<std::string>{"trainer.lr", "eval.splits"}));
}

TEST(RunDirectoryTest, FreshRunRefusesANonEmptyDirectory) {
  vln::test::TempDir dir;
  EXPECT_NO_THROW(checkFreshRunDirectory(dir / "new"));
  EXPECT_NO_THROW(checkFreshRunDirectory(dir.path()));
  vln::test::writeText(dir / "config.yaml", "x");
  EXPECT_THAT([&] { checkFreshRunDirectory(dir.path()); },
              ::testing::ThrowsMessage<std::invalid_argument>(::testing::AllOf(
                  HasSubstr(dir.path().string()), HasSubstr("--resume"))));
}

TEST(RunDirectoryTest,
     ASecondProcessOnTheRunDirectoryIsRefusedUntilTheFirstEnds) {
  vln::test::TempDir dir;
  {
    RunDirectoryLock first(dir.path());
    // a second open file description conflicts as another process's would
    EXPECT_THAT(
        [&] { RunDirectoryLock second(dir.path()); },
        ::testing::ThrowsMessage<std::invalid_argument>(
            ::testing::AllOf(HasSubstr(dir.path().string()),
                             HasSubstr("in use by another train process"),
                             HasSubstr("pid " + std::to_string(::getpid())))));
  }
  EXPECT_NO_THROW(RunDirectoryLock again(dir.path()));
}

TEST(RunDirectoryTest, ResumeAllowsOnlyExplicitSafeChanges) {
  vln::test::TempDir dir;
  ExperimentConfig stored;
  stored.output.dir = dir.path().string();
  common::writeFileAtomic(dir / "config.yaml", experimentConfigYaml(stored));

  EXPECT_TRUE(checkResumeConfig(dir.path(), stored, {}).empty());

  ExperimentConfig more = stored;
  more.trainer.epochs = 50;
  more.trainer.torch_threads = 4;
  // safe keys given with --set are allowed and reported
  EXPECT_EQ(
      checkResumeConfig(dir.path(), more,
                        {"trainer.epochs", "trainer.torch_threads"}),
      (std::vector<std::string>{"trainer.torch_threads", "trainer.epochs"}));
  // the same change not given explicitly (e.g. an edited YAML) is refused
  EXPECT_THAT([&] { checkResumeConfig(dir.path(), more, {"trainer.epochs"}); },
              ::testing::ThrowsMessage<std::invalid_argument>(::testing::AllOf(
                  HasSubstr("trainer.torch_threads: run has 2, requested 4"),
                  Not(HasSubstr("trainer.epochs")))));

  ExperimentConfig unsafe = stored;
  unsafe.trainer.lr = 0.5;
  unsafe.model.hidden_size = 7;
  try {
    checkResumeConfig(dir.path(), unsafe, {"trainer.lr"});
    FAIL() << "expected an error";
  } catch (const std::invalid_argument& error) {
    EXPECT_THAT(error.what(), HasSubstr("2 key(s)"));
    EXPECT_THAT(error.what(), HasSubstr("trainer.lr"));
    EXPECT_THAT(error.what(),
                HasSubstr("model.hidden_size: run has 512, requested 7"));
  }
  EXPECT_THAT([&] { checkResumeConfig(dir / "nothing", stored, {}); },
              ::testing::ThrowsMessage<std::invalid_argument>(
                  HasSubstr("no run to resume")));
}

}  // namespace
}  // namespace vln::train
