#include "common/Config.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "support/TestPaths.h"

namespace vln::common {
namespace {

using ::testing::HasSubstr;

enum class Mode { kFast, kSlow };

struct InnerConfig {
  double lr = 2.5e-4;
  std::vector<int> sizes = {1, 2};
  Mode mode = Mode::kFast;
  void visit(ConfigVisitor& v) {
    v.field("lr", lr, "Learning rate", inRange(0.0, 1.0));
    v.field("sizes", sizes, "Layer sizes", atLeast(1));
    v.enumeration("mode", mode, {{"fast", Mode::kFast}, {"slow", Mode::kSlow}},
                  "Speed mode");
  }
  bool operator==(const InnerConfig&) const = default;
};

struct RootConfig {
  int batch = 5;
  bool flag = false;
  std::string name = "default";
  InnerConfig trainer;
  void visit(ConfigVisitor& v) {
    v.field("batch", batch, "Episodes per batch", atLeast(1));
    v.field("flag", flag, "A flag");
    v.field("name", name, "A name");
    v.section("trainer", trainer, "Trainer settings");
  }
  bool operator==(const RootConfig&) const = default;
};

TEST(ConfigTest, ReadsValuesAndKeepsDefaults) {
  auto c = loadConfigText<RootConfig>("batch: 7\ntrainer:\n  mode: slow\n");
  EXPECT_EQ(c.batch, 7);
  EXPECT_EQ(c.trainer.mode, Mode::kSlow);
  EXPECT_DOUBLE_EQ(c.trainer.lr, 2.5e-4);
  EXPECT_EQ(c.name, "default");
}

TEST(ConfigTest, UnknownKeyIsAnErrorWithPathAndHint) {
  try {
    loadConfigText<RootConfig>("trainer:\n  lrr: 0.1\n", "cfg.yaml");
    FAIL() << "expected an error";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("cfg.yaml:2"));
    EXPECT_THAT(e.what(), HasSubstr("unknown key 'trainer.lrr'"));
    EXPECT_THAT(e.what(), HasSubstr("did you mean 'trainer.lr'"));
  }
}

TEST(ConfigTest, WrongTypesAndRangesNameTheKey) {
  // each file text (called `source` in errors) is rejected with a message
  // holding `message`
  const struct {
    const char* text;
    const char* source;
    const char* message;
  } cases[] = {
      {"batch: many\n", "x.yaml",
       "key 'batch': expected an integer, got 'many'"},
      {"batch: 1.5\n", "<string>", "expected an integer"},
      {"trainer: {lr: 3}\n", "<string>",
       "key 'trainer.lr': value 3 is outside [0, 1]"},
      {"trainer: {mode: turbo}\n", "<string>",
       "expected one of {fast, slow}, got 'turbo'"},
      {"trainer: 3\n", "<string>", "expected a mapping"},
      {"batch: [1\n", "bad.yaml", "bad.yaml:"},
      {"flag:\n", "<string>", "key 'flag': value is empty"},
  };
  for (const auto& c : cases)
    EXPECT_THAT(
        [&] { loadConfigText<RootConfig>(c.text, c.source); },
        ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr(c.message)))
        << c.text;
}

TEST(ConfigTest, OverridesApplyAfterTheFile) {
  auto c = loadConfigText<RootConfig>(
      "batch: 7\n", "<s>", {"trainer.lr=0.5", "batch=9", "trainer.sizes=[3,4]"});
  EXPECT_EQ(c.batch, 9);
  EXPECT_DOUBLE_EQ(c.trainer.lr, 0.5);
  EXPECT_EQ(c.trainer.sizes, (std::vector<int>{3, 4}));
  EXPECT_THROW(loadConfigText<RootConfig>("", "<s>", {"trainer.nope=1"}),
               std::invalid_argument);
  EXPECT_THROW(loadConfigText<RootConfig>("", "<s>", {"novalue"}),
               std::invalid_argument);
}

TEST(ConfigTest, OverrideErrorsNameTheOverride) {
  // `train --config main.yaml --set trainer.lr=-1` blamed main.yaml:1
  test::TempDir dir;
  const auto file =
      test::writeText(dir / "run.yaml", "batch: 7\ntrainer:\n  lr: 0.1\n");
  const auto errorOf = [&](std::vector<std::string> overrides) {
    try {
      loadConfigFile<RootConfig>(file, overrides);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_THAT(errorOf({"trainer.lr=-1"}),
              HasSubstr("--set trainer.lr=-1: key 'trainer.lr': value -1 is "
                        "outside [0, 1]"));
  EXPECT_THAT(
      errorOf({"batch=8", "trainer.lr=x"}),
      HasSubstr("--set trainer.lr=x: key 'trainer.lr': expected a number"));
  EXPECT_THAT(errorOf({"trainer.lrr=0.1"}),
              HasSubstr("--set trainer.lrr=0.1: unknown key 'trainer.lrr'"));
  // a mapping given whole, and a key set below a scalar
  EXPECT_THAT(errorOf({"trainer={lr: 2}"}),
              HasSubstr("--set trainer={lr: 2}: key 'trainer.lr'"));
  EXPECT_THAT(errorOf({"batch.x=1"}),
              HasSubstr("--set batch.x=1: key 'batch': expected an integer"));
  // the last override of a key is the one named
  EXPECT_THAT(errorOf({"trainer.lr=5", "trainer.lr=6"}),
              HasSubstr("--set trainer.lr=6:"));
  // errors in the file itself still name the file and the line
  test::writeText(dir / "bad.yaml", "batch: 7\ntrainer:\n  lr: 9\n");
  EXPECT_THAT(
      [&] { loadConfigFile<RootConfig>(dir / "bad.yaml", {"batch=3"}); },
      ::testing::ThrowsMessage<std::invalid_argument>(
          HasSubstr("bad.yaml:3: key 'trainer.lr'")));
}

TEST(ConfigTest, ASectionOfALargerConfigIsReadAlone) {
  // a tool that knows only the trainer section (vlnce-sim reads `sim`)
  test::TempDir dir;
  test::writeText(dir / "base.yaml", "trainer:\n  lr: 0.25\nother: {x: 1}\n");
  const auto file = test::writeText(
      dir / "run.yaml",
      "_base_: base.yaml\nbatch: 7\nunknown: 3\ntrainer:\n  mode: slow\n");
  InnerConfig trainer;
  const ConfigVisitFn visit = [&](ConfigVisitor& v) {
    v.section("trainer", trainer, "Trainer settings");
  };
  readConfigFileSection(file, "trainer", {}, visit);
  EXPECT_DOUBLE_EQ(trainer.lr, 0.25);
  EXPECT_EQ(trainer.mode, Mode::kSlow);
  readConfigFileSection(file, "trainer", {"trainer.lr=0.5"}, visit);
  EXPECT_DOUBLE_EQ(trainer.lr, 0.5);
  // strict inside the section, with the file and line named
  test::writeText(dir / "typo.yaml", "batch: 7\ntrainer:\n  lrr: 0.5\n");
  EXPECT_THAT(
      [&] { readConfigFileSection(dir / "typo.yaml", "trainer", {}, visit); },
      ::testing::ThrowsMessage<std::invalid_argument>(
          HasSubstr("typo.yaml:3: unknown key 'trainer.lrr'")));
  // a file without the section leaves the defaults
  InnerConfig untouched;
  readConfigFileSection(dir / "base.yaml", "absent", {}, [&](ConfigVisitor& v) {
    v.section("absent", untouched, "");
  });
  EXPECT_EQ(untouched, InnerConfig{});
}

TEST(ConfigTest, WrittenYamlRoundTrips) {
  RootConfig original;
  original.batch = 11;
  original.name = "with: colon";
  original.trainer.lr = 0.125;
  original.trainer.mode = Mode::kSlow;
  std::string yaml = configToYaml(original);
  EXPECT_THAT(yaml, HasSubstr("# Episodes per batch"));
  auto reread = loadConfigText<RootConfig>(yaml);
  EXPECT_EQ(reread, original);
}

TEST(ConfigTest, BaseFilesMergeUnderneath) {
  test::TempDir dir;
  test::writeText(dir / "base.yaml", "batch: 3\ntrainer:\n  lr: 0.25\n  mode: slow\n");
  test::writeText(dir / "child.yaml", "_base_: base.yaml\ntrainer:\n  lr: 0.5\n");
  auto c = loadConfigFile<RootConfig>(dir / "child.yaml");
  EXPECT_EQ(c.batch, 3);
  EXPECT_DOUBLE_EQ(c.trainer.lr, 0.5);
  EXPECT_EQ(c.trainer.mode, Mode::kSlow);
  EXPECT_THROW(loadConfigFile<RootConfig>(dir / "missing.yaml"), std::runtime_error);
}

TEST(ConfigTest, CheckConfigCatchesValuesSetInCode) {
  RootConfig c;
  c.batch = 0;
  EXPECT_THAT([&] { checkConfig([&](ConfigVisitor& v) { c.visit(v); }, "code"); },
              ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("key 'batch'")));
  // float fields at their bounds pass although 0.02f < 0.02
  struct FloatConfig {
    float thickness = 0.02f;
    void visit(ConfigVisitor& v) { v.field("thickness", thickness, "t", inRange(0.02, 0.5)); }
  } f;
  EXPECT_NO_THROW(checkConfig([&](ConfigVisitor& v) { f.visit(v); }, "code"));
  f.thickness = 0.0199f;
  EXPECT_THROW(checkConfig([&](ConfigVisitor& v) { f.visit(v); }, "code"), std::invalid_argument);
  auto keys = configKeys([&](ConfigVisitor& v) { c.visit(v); });
  EXPECT_EQ(keys.back(), "trainer.mode");
}

}  // namespace
}  // namespace vln::common
