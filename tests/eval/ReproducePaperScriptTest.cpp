// scripts/reproduce_paper.sh and the shell functions it shares with
// scripts/run.sh (scripts/common.sh): syntax, the order in which the seeds
// of the experiments run (--plan, which runs nothing), and the helpers that
// read the resolved config, complete the default world and splice generated
// text into docs/results.md.
// None of this trains anything.
#include <algorithm>
#include <map>
#include <sstream>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "common/FileIo.h"
#include "support/TestPaths.h"

namespace vln {
namespace {

using ::testing::HasSubstr;

std::string script(const std::string& name) {
  return (test::sourcePath() / "scripts" / name).string();
}

// Runs `command` with bash from the repository root; returns its status.
int bash(const std::string& command, std::string* output) {
  return test::runCommand(
      "cd " + test::sourcePath().string() + " && bash -c '" + command + "'",
      output);
}

struct Step {
  int seed = 0;
  std::string name, run, results;
};

std::vector<Step> plan(const std::string& environment,
                       const std::string& args = "") {
  std::string output;
  EXPECT_EQ(test::runCommand(environment + " " + script("reproduce_paper.sh") +
                                 " --plan " + args,
                             &output),
            0)
      << output;
  std::vector<Step> steps;
  std::istringstream lines(output);
  for (std::string word, line; std::getline(lines, line);) {
    std::istringstream in(line);
    Step step;
    in >> word >> step.seed >> step.name >> step.run >> step.results;
    EXPECT_EQ(word, "seed") << line;
    steps.push_back(step);
  }
  return steps;
}

// The experiment a configs/experiments config fine-tunes (its
// init_checkpoint, a run directory of the script), or "".
std::string fineTunes(const std::string& name) {
  const std::string text = common::readFile(test::sourcePath() / "configs" /
                                            "experiments" / (name + ".yaml"));
  const std::string key = "init_checkpoint: runs/experiments/";
  const size_t at = text.find(key);
  if (at == std::string::npos) return "";
  const size_t from = at + key.size();
  return text.substr(from, text.find('\n', from) - from);
}

TEST(ReproducePaperScriptTest, ScriptsParse) {
  for (const char* name : {"reproduce_paper.sh", "run.sh", "common.sh"}) {
    std::string output;
    EXPECT_EQ(test::runCommand("bash -n " + script(name), &output), 0)
        << name << ": " << output;
  }
}

// Seed 0 of every experiment before seed 1 of any; every seed runs every
// experiment and both baselines, a DA* run after the run it fine-tunes.
TEST(ReproducePaperScriptTest, SeedsRunSeedMajor) {
  const auto steps = plan("VLN_SEEDS=3");
  ASSERT_FALSE(steps.empty());
  ASSERT_EQ(steps.size() % 3, 0u);
  const size_t perSeed = steps.size() / 3;
  std::vector<std::string> first;
  for (size_t i = 0; i < steps.size(); ++i) {
    const Step& step = steps[i];
    EXPECT_EQ(step.seed, static_cast<int>(i / perSeed)) << step.name;
    if (i < perSeed) first.push_back(step.name);
    EXPECT_EQ(step.name, first[i % perSeed]) << "seed " << step.seed;
    // the baselines train nothing; a run that is no row has no results
    const std::string seedDir = "/seed" + std::to_string(step.seed);
    const bool baseline = step.name == "random" || step.name == "handcrafted";
    EXPECT_EQ(step.run,
              baseline ? "-" : "runs/experiments/" + step.name + seedDir);
    EXPECT_THAT(step.results,
                ::testing::AnyOf("-", "results/paper/" + step.name + seedDir));
    if (baseline || step.name == "seq2seq" || step.name == "cma") {
      EXPECT_NE(step.results, "-") << step.name;
    }
  }

  // every experiment config and both baselines, each once per seed
  std::vector<std::string> expected = {"random", "handcrafted"};
  for (const auto& entry : std::filesystem::directory_iterator(
           test::sourcePath() / "configs" / "experiments"))
    expected.push_back(entry.path().stem().string());
  std::vector<std::string> sorted = first;
  std::sort(sorted.begin(), sorted.end());
  std::sort(expected.begin(), expected.end());
  EXPECT_EQ(sorted, expected);

  std::map<std::string, size_t> position;
  for (size_t i = 0; i < first.size(); ++i) position[first[i]] = i;
  int fineTuning = 0;
  for (const auto& name : first) {
    if (name == "random" || name == "handcrafted") continue;  // no config
    const std::string base = fineTunes(name);
    if (base.empty()) continue;
    ++fineTuning;
    ASSERT_TRUE(position.contains(base)) << name << " fine-tunes " << base;
    EXPECT_LT(position[base], position[name]) << name;
  }
  EXPECT_GT(fineTuning, 0);
}

TEST(ReproducePaperScriptTest, NamedExperimentsAndBadInput) {
  const auto steps = plan("VLN_SEEDS=2", "cma random");
  ASSERT_EQ(steps.size(), 4u);
  EXPECT_EQ(steps[0].name, "cma");
  EXPECT_EQ(steps[1].name, "random");
  EXPECT_EQ(steps[3].seed, 1);
  EXPECT_EQ(plan("env -u VLN_SEEDS", "seq2seq").size(), 3u);  // default 3

  std::string output;
  EXPECT_EQ(test::runCommand(
                script("reproduce_paper.sh") + " --plan cma nonsense", &output),
            2);
  EXPECT_THAT(output, HasSubstr("unknown run 'nonsense'"));
  EXPECT_EQ(
      test::runCommand(
          "VLN_SEEDS=0 " + script("reproduce_paper.sh") + " --plan", &output),
      2);
  EXPECT_THAT(output,
              HasSubstr("VLN_SEEDS must be a positive integer, got '0'"));
}

// vln_config_value reads SECTION.KEY at the top level of the section of
// `train --dry-run`'s YAML, unquoted; the dry run here is a stand-in.
TEST(ReproducePaperScriptTest, ConfigValueReadsTheResolvedConfig) {
  test::TempDir dir;
  test::writeText(dir / "dry.yaml",
                  "trainer:\n  # Seed of everything\n  seed: 4\n"
                  "  init_checkpoint: \"\"\n  nested:\n    seed: 9\n"
                  "output:\n  dir: runs/x/seed4\n");
  test::writeText(dir / "bin" / "train",
                  "#!/bin/sh\ncat " + (dir / "dry.yaml").string() + "\n");
  std::string output;
  ASSERT_EQ(
      test::runCommand("chmod +x " + (dir / "bin" / "train").string(), &output),
      0);
  ASSERT_EQ(bash("vln_bin=" + (dir / "bin").string() +
                     "; source scripts/common.sh; "
                     "echo \"[$(vln_config_value c trainer seed)]"
                     "[$(vln_config_value c output dir --set a=b)]"
                     "[$(vln_config_value c trainer init_checkpoint)]"
                     "[$(vln_config_value c trainer absent)]\"",
                 &output),
            0)
      << output;
  EXPECT_EQ(output, "[4][runs/x/seed4][][]\n");
}

// vln_ensure_world generates the default world where there is none, adds
// train_extra in place to a world from before the 112 extra train houses
// (keeping what is there: other worlds' scenes, the world's own files), and
// leaves a complete world alone. A stub vlnce-data records its calls.
TEST(ReproducePaperScriptTest, EnsureWorldGeneratesOrCompletesTheDefaultWorld) {
  test::TempDir dir;
  const std::string d = dir.path().string();
  test::writeText(dir / "bin" / "vlnce-data",
                  "#!/bin/sh\necho \"$*\" >> " + d + "/calls\n"
                  "mkdir -p data/datasets/procedural/train_extra\n"
                  "touch data/datasets/procedural/generation_stats.json "
                  "data/datasets/procedural/train_extra/train_extra.json.gz\n");
  std::string output;
  ASSERT_EQ(test::runCommand("chmod +x " + d + "/bin/vlnce-data", &output), 0);
  const std::string ensure = "cd " + d + " && vln_bin=" + d +
                             "/bin; source " + script("common.sh") +
                             "; vln_ensure_world";
  auto calls = [&] {
    return std::filesystem::exists(dir / "calls") ? common::readFile(dir / "calls")
                                                  : std::string();
  };

  // none: generated, and a stale scenes directory of the default world is
  // cleared first
  test::writeText(dir / "data" / "scene_datasets" / "procedural" / "stale", "x");
  ASSERT_EQ(bash(ensure, &output), 0) << output;
  EXPECT_THAT(calls(), HasSubstr("generate --config configs/world/default.yaml "
                                 "--out data/datasets/procedural"));
  EXPECT_FALSE(std::filesystem::exists(dir / "data" / "scene_datasets" /
                                       "procedural" / "stale"));

  // complete: left alone
  std::filesystem::remove(dir / "calls");
  ASSERT_EQ(bash(ensure, &output), 0) << output;
  EXPECT_EQ(calls(), "");

  // from before the extra houses: completed in place, nothing removed
  std::filesystem::remove_all(dir / "data" / "datasets" / "procedural" /
                              "train_extra");
  test::writeText(dir / "data" / "scene_datasets" / "procedural" / "other", "x");
  test::writeText(dir / "data" / "datasets" / "procedural" / "mine", "x");
  ASSERT_EQ(bash(ensure, &output), 0) << output;
  EXPECT_THAT(output, HasSubstr("adding the 112 extra train houses"));
  EXPECT_THAT(calls(), HasSubstr("generate --config configs/world/default.yaml"));
  EXPECT_TRUE(std::filesystem::exists(dir / "data" / "scene_datasets" /
                                      "procedural" / "other"));
  EXPECT_TRUE(
      std::filesystem::exists(dir / "data" / "datasets" / "procedural" / "mine"));
}

// vln_splice replaces one marked block, keeps the prose and the other
// blocks, and appends a block a document lacks.
TEST(ReproducePaperScriptTest, SpliceReplacesOnlyItsBlock) {
  test::TempDir dir;
  const auto doc = test::writeText(
      dir / "results.md",
      "# Results\n\nprose\n\n<!-- tables:begin -->\nold tables\n"
      "<!-- tables:end -->\n\nmore prose\n\n<!-- findings:begin -->\nold "
      "findings\n<!-- findings:end -->\ntail\n");
  test::writeText(dir / "tables.md", "new tables\n");
  test::writeText(dir / "other.md", "other");
  const std::string d = dir.path().string();
  std::string output;
  ASSERT_EQ(bash("source scripts/common.sh; vln_splice tables " + d +
                     "/tables.md " + d + "/results.md && vln_splice other " +
                     d + "/other.md " + d + "/results.md",
                 &output),
            0)
      << output;
  EXPECT_EQ(common::readFile(doc),
            "# Results\n\nprose\n\n<!-- tables:begin -->\nnew tables\n"
            "<!-- tables:end -->\n\nmore prose\n\n<!-- findings:begin -->\nold "
            "findings\n<!-- findings:end -->\ntail\n"
            "<!-- other:begin -->\nother\n<!-- other:end -->\n");
}

}  // namespace
}  // namespace vln
