// Config strictness: every YAML file under configs/ loads with its loader,
// a typo in any one of its keys is an error naming that key, and the same
// holds for every key of the full resolved run config. Loading checkpoint
// tensors into a model they do not fit lists every mismatch and changes
// nothing.
//
// Which loader a file under configs/ gets: files below a directory named
// "world" are world::WorldConfig (vlnce-data generate --config); every other
// file must be an ExperimentConfig (train/eval --config), i.e. its top-level
// keys are sections of ExperimentConfig (or _base_). A file that fits
// neither fails the test, so a new kind of config cannot go unchecked.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>
#include <regex>
#include <set>
#include <sstream>

#include "common/Config.h"
#include "models/Policy.h"
#include "models/StateDict.h"
#include "support/TestPaths.h"
#include "train/Checkpoint.h"
#include "train/ExperimentConfig.h"
#include "world/RxrWorldConfig.h"
#include "world/WorldConfig.h"

namespace vln::reliability {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

std::string readText(const fs::path& file) {
  std::ifstream in(file);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

enum class Kind { kWorld, kRxrWorld, kExperiment };

const std::set<std::string>& experimentSections() {
  static const std::set<std::string> sections = {
      "sim",  "task",   "dataset",  "model",    "trainer",        "pretrain",
      "eval", "output", "panorama", "waypoint", "waypoint_agent", "_base_"};
  return sections;
}

// strict load of `text` as `kind`, includes resolved against `baseDir`
void load(Kind kind, std::string_view text, const std::string& source,
          const fs::path& baseDir) {
  if (kind == Kind::kRxrWorld) {
    world::RxrWorldConfig config;
    common::readConfig(text, source, baseDir, {},
                       [&](common::ConfigVisitor& v) { config.visit(v); });
    config.validate();
  } else if (kind == Kind::kWorld) {
    world::WorldConfig config;
    common::readConfig(text, source, baseDir, {},
                       [&](common::ConfigVisitor& v) { config.visit(v); });
    config.validate();
  } else {
    train::ExperimentConfig config;
    common::readConfig(text, source, baseDir, {},
                       [&](common::ConfigVisitor& v) { config.visit(v); });
    config.validate();
  }
}

// one key occurrence in YAML text: block keys ("  name:") and flow-map keys
// ("{width: 32, height: 32}"), comments skipped
struct KeyToken {
  size_t offset = 0;
  std::string name;
};

std::vector<KeyToken> keyTokens(const std::string& text) {
  static const std::regex key(
      R"((^[ \t]*(?:-[ \t]+)?|[{,][ \t]*)([A-Za-z_][A-Za-z0-9_]*)[ \t]*:(?=[ \t]|$))");
  std::vector<KeyToken> tokens;
  size_t lineStart = 0;
  while (lineStart < text.size()) {
    size_t lineEnd = text.find('\n', lineStart);
    if (lineEnd == std::string::npos) lineEnd = text.size();
    std::string line = text.substr(lineStart, lineEnd - lineStart);
    // a comment starts at a '#' at the line start or after a blank
    for (size_t i = 0; i < line.size(); ++i)
      if (line[i] == '#' &&
          (i == 0 || line[i - 1] == ' ' || line[i - 1] == '\t')) {
        line.resize(i);
        break;
      }
    for (auto it = std::sregex_iterator(line.begin(), line.end(), key);
         it != std::sregex_iterator(); ++it) {
      const auto& m = *it;
      tokens.push_back(
          {lineStart + static_cast<size_t>(m.position(2)), m.str(2)});
    }
    lineStart = lineEnd + 1;
  }
  return tokens;
}

// loads `text`, then every single-key typo of it; returns the keys checked
int checkEveryKeyTypo(Kind kind, const std::string& text,
                      const std::string& source, const fs::path& baseDir) {
  EXPECT_NO_THROW(load(kind, text, source, baseDir)) << source;
  const auto tokens = keyTokens(text);
  for (const auto& token : tokens) {
    const std::string typo = token.name + "_x";
    std::string mutated = text;
    mutated.replace(token.offset, token.name.size(), typo);
    SCOPED_TRACE(source + ": key '" + token.name + "' misspelt '" + typo + "'");
    try {
      load(kind, mutated, source, baseDir);
      ADD_FAILURE() << "the misspelt key was accepted";
    } catch (const std::invalid_argument& e) {
      EXPECT_THAT(e.what(), HasSubstr("unknown key"));
      EXPECT_THAT(e.what(), HasSubstr(typo + "'"));
      EXPECT_THAT(e.what(), HasSubstr(source));
    }
  }
  return static_cast<int>(tokens.size());
}

Kind classify(const fs::path& file) {
  // only the directories below configs/ count: the checkout itself may sit
  // in a directory named world
  const fs::path configs = vln::test::sourcePath() / "configs";
  const std::string text = readText(file);
  for (const auto& part : file.lexically_relative(configs)) {
    if (part != "world") continue;
    // the RxR split's config nests a whole world under `world:` (as
    // vlnce-data generate tells them apart)
    for (const auto& token : keyTokens(text))
      if (token.name == "world" &&
          (token.offset == 0 || text[token.offset - 1] == '\n'))
        return Kind::kRxrWorld;
    return Kind::kWorld;
  }
  // top-level keys: unindented block keys
  for (const auto& token : keyTokens(text)) {
    const bool topLevel = token.offset == 0 || text[token.offset - 1] == '\n';
    if (topLevel && !experimentSections().count(token.name))
      throw std::invalid_argument(
          file.string() +
          ": neither a world config (configs/**/world/) "
          "nor a run config (top-level key '" +
          token.name + "')");
  }
  return Kind::kExperiment;
}

std::vector<fs::path> configFiles() {
  std::vector<fs::path> files;
  for (const auto& entry :
       fs::recursive_directory_iterator(vln::test::sourcePath() / "configs"))
    if (entry.is_regular_file() && (entry.path().extension() == ".yaml" ||
                                    entry.path().extension() == ".yml"))
      files.push_back(entry.path());
  std::sort(files.begin(), files.end());
  return files;
}

TEST(ConfigStrictnessTest, KeyTokensFindBlockAndFlowKeys) {
  const auto tokens = keyTokens(
      "# a: comment\nsim:\n  rgb: {width: 32, height: 3}  # b: no\n  list:\n   "
      " - x: 1\n"
      "url: 'http://a'\n");
  std::vector<std::string> names;
  for (const auto& t : tokens) names.push_back(t.name);
  EXPECT_EQ(names, (std::vector<std::string>{"sim", "rgb", "width", "height",
                                             "list", "x", "url"}));
}

TEST(ConfigStrictnessTest, EveryConfigFileLoadsAndRejectsEveryKeyTypo) {
  const auto files = configFiles();
  ASSERT_FALSE(files.empty());
  int keys = 0;
  for (const auto& file : files) {
    SCOPED_TRACE(file.string());
    Kind kind{};
    ASSERT_NO_THROW(kind = classify(file));
    keys += checkEveryKeyTypo(kind, readText(file), file.string(),
                              file.parent_path());
  }
  RecordProperty("config_files", static_cast<int>(files.size()));
  RecordProperty("keys_mutated", keys);
  EXPECT_GT(keys, 20);
}

// the full resolved run config names every key of every section: each one
// misspelt must be refused with its name
TEST(ConfigStrictnessTest, EveryRunConfigKeyTypoIsRefused) {
  const train::ExperimentConfig defaults;
  const std::string yaml = train::experimentConfigYaml(defaults);
  const int mutated =
      checkEveryKeyTypo(Kind::kExperiment, yaml, "resolved.yaml", ".");
  train::ExperimentConfig copy = defaults;
  const auto leafKeys =
      common::configKeys([&](common::ConfigVisitor& v) { copy.visit(v); });
  // every leaf key plus the section headers was mutated once
  EXPECT_GE(mutated, static_cast<int>(leafKeys.size()) + 8);
}

// the same for a world config written out in full
TEST(ConfigStrictnessTest, EveryWorldConfigKeyTypoIsRefused) {
  const world::WorldConfig defaults;
  const std::string yaml = common::configToYaml(defaults);
  const int mutated = checkEveryKeyTypo(Kind::kWorld, yaml, "world.yaml", ".");
  world::WorldConfig copy = defaults;
  EXPECT_GE(mutated,
            static_cast<int>(common::configKeys([&](common::ConfigVisitor& v) {
                               copy.visit(v);
                             }).size()));
}

// a misspelt override is refused too (the --set path)
TEST(ConfigStrictnessTest, MisspeltOverrideIsRefused) {
  vln::test::TempDir dir;
  const fs::path file =
      vln::test::writeText(dir / "run.yaml", "trainer:\n  seed: 1\n");
  try {
    train::loadExperimentConfig(file, {"trainer.learning_rate=0.1"});
    FAIL() << "accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("trainer.learning_rate"));
    // the error names the override, not a line of run.yaml
    EXPECT_THAT(e.what(), HasSubstr("--set trainer.learning_rate=0.1: "));
  }
  // an out-of-range value given by --set (issue 19: was blamed on line 1)
  EXPECT_THAT([&] { train::loadExperimentConfig(file, {"trainer.lr=-1"}); },
              ::testing::ThrowsMessage<std::invalid_argument>(
                  HasSubstr("--set trainer.lr=-1: key 'trainer.lr'")));
}

models::ModelConfig smallModel(int hidden, bool progressMonitor) {
  return common::loadConfigText<models::ModelConfig>(
      "policy: cma\nrgb_encoder: small_cnn\ndepth_encoder: small_cnn\n"
      "vocab_size: 20\nembedding_dim: 8\ninstruction_hidden_size: 8\n"
      "hidden_size: " +
      std::to_string(hidden) +
      "\nprev_action_embedding_dim: 4\n"
      "rgb_projection_size: 8\ndepth_projection_size: "
      "8\nspatial_embedding_dim: 4\n"
      "progress_monitor: " +
      (progressMonitor ? "true" : "false") +
      "\n"
      "rgb_height: 32\nrgb_width: 32\ndepth_height: 32\ndepth_width: 32\n");
}

// a checkpoint of one model loaded into another: every missing, unexpected
// and reshaped tensor is named, and the target keeps its weights
TEST(ConfigStrictnessTest, MismatchedCheckpointListsEveryTensor) {
  torch::manual_seed(1);
  auto saved =
      models::makePolicy(smallModel(/*hidden=*/16, /*progressMonitor=*/true));
  auto target =
      models::makePolicy(smallModel(/*hidden=*/24, /*progressMonitor=*/false));
  vln::test::TempDir dir;
  train::Checkpoint checkpoint;
  checkpoint.policy = models::namedState(*saved);
  const fs::path file = dir / "ckpt.0.pth";
  train::saveCheckpoint(file, checkpoint);
  const train::Checkpoint loaded = train::loadCheckpoint(file);
  ASSERT_EQ(loaded.policy.size(), checkpoint.policy.size());

  std::map<std::string, std::vector<int64_t>> have, want;
  for (const auto& [name, t] : loaded.policy) have[name] = t.sizes().vec();
  std::map<std::string, torch::Tensor> before;
  for (const auto& [name, t] : models::namedState(*target)) {
    want[name] = t.sizes().vec();
    before[name] = t.clone();
  }
  std::vector<std::string> offenders;
  for (const auto& [name, shape] : want)
    if (!have.count(name) || have[name] != shape) offenders.push_back(name);
  for (const auto& [name, shape] : have)
    if (!want.count(name)) offenders.push_back(name);
  ASSERT_GE(offenders.size(), 3u);

  try {
    models::loadStateStrict(*target, loaded.policy, file.string());
    FAIL() << "a mismatched checkpoint was loaded";
  } catch (const std::invalid_argument& e) {
    const std::string message = e.what();
    EXPECT_THAT(message, HasSubstr(file.string()));
    for (const auto& name : offenders) EXPECT_THAT(message, HasSubstr(name));
  }
  for (const auto& [name, t] : models::namedState(*target))
    EXPECT_TRUE(torch::equal(t, before.at(name))) << name << " changed";
}

}  // namespace
}  // namespace vln::reliability
