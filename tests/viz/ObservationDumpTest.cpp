// Observation dumps (src/viz/ObservationDump.cpp) of the oracle on the small
// generated house, watched beside a spy observer through
// rollout::EpisodeObservers: the PNGs decode back to the observations the
// agent was shown (RGB exactly, depth in millimetres), the step records hold
// the evaluator's poses and actions, only the chosen episodes are written,
// an episode's folder is complete or absent, nothing is overwritten; and
// scripts/read_observation_dump.py reads a dump back with the same pixels.

#include "viz/ObservationDump.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <map>

#include "common/Json.h"
#include "rollout/Evaluator.h"
#include "rollout/RolloutTestWorld.h"
#include "rollout/WaypointOracle.h"
#include "support/TestPaths.h"
#include "support/TestUtil.h"

namespace vln::viz {
namespace {

namespace fs = std::filesystem;
using rollout::test::rolloutTestWorld;
using ::testing::HasSubstr;

// What an observer saw of an episode: the observation and pose per frame.
struct Seen {
  std::vector<sim::Observation> frames;
  std::vector<sim::AgentState> poses;
};

// Records what it is shown of every episode, wanting no frames itself.
class SpyObserver : public rollout::EpisodeObserver {
 public:
  bool wantsFrames(int) const override { return false; }
  void episodeStarted(int index, rollout::VectorEnv& envs, int env) override {
    record(index, envs, env);
  }
  void episodeStepped(int index, rollout::VectorEnv& envs, int env,
                      sim::Action) override {
    record(index, envs, env);
  }
  void episodeFinished(int, rollout::VectorEnv&, int,
                       const rollout::EpisodeResult&, bool) override {}
  std::map<int, Seen> seen;  ///< by input position

 private:
  void record(int index, rollout::VectorEnv& envs, int env) {
    seen[index].frames.push_back(envs.observation(env));
    seen[index].poses.push_back(envs.state(env).agent);
  }
};

DumpConfig dumpConfig(const fs::path& dir) {
  const auto& w = rolloutTestWorld();
  DumpConfig c;
  c.dir = dir;
  c.split = "val_seen";
  c.rgb = w.sim.rgb;
  c.depth = w.sim.depth;
  c.agent = "oracle";
  return c;
}

// The oracle over the house's episodes with `dump` and a spy watching.
rollout::EvaluationResult runOracle(ObservationDump& dump, SpyObserver& spy,
                                    int numEnvs) {
  const auto& w = rolloutTestWorld();
  rollout::OracleAgent agent(w.sim.agent, w.task.follower_goal_radius,
                             rollout::OracleMode::kGoal, numEnvs);
  rollout::VectorEnv envs(numEnvs, w.sim, w.task,
                          std::make_shared<rollout::SceneCache>(w.sim), 2);
  rollout::EpisodeObservers observers;
  observers.add(&dump);
  observers.add(&spy);
  observers.add(nullptr);
  EXPECT_EQ(observers.size(), 2u);
  return rollout::evaluateEpisodes(agent, envs, w.episodes, &w.groundTruth,
                                   rollout::EvalConfig{}, {},
                                   observers.single());
}

// Millimetres of a post-processed depth value, written out independently
// of depthMillimetres() (in double: the two may round a half millimetre
// apart): undo [min, max] -> [0, 1], 0 at the far clip.
int expectedMillimetres(float v, const sim::DepthCameraConfig& c) {
  const double metres =
      c.normalize_depth ? c.min_depth + double(v) * (c.max_depth - c.min_depth)
                        : double(v);
  if (metres >= c.max_depth - 0.0005 || metres <= 0.0 || metres > 65.535)
    return 0;
  return static_cast<int>(std::lround(metres * 1000.0));
}

// The first two episodes dumped, once for the suite.
class ObservationDumpTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new vln::test::TempDir();
    spy_ = new SpyObserver();
    DumpConfig c = dumpConfig(dir_->path());
    c.first_episodes = 2;
    ObservationDump dump(c, rolloutTestWorld().episodes);
    EXPECT_EQ(dump.chosen(), 2);
    result_ = new rollout::EvaluationResult(runOracle(dump, *spy_, 3));
    folders_ = dump.folders();
  }
  static void TearDownTestSuite() {
    delete result_;
    delete spy_;
    delete dir_;
  }
  static fs::path folder(int index) {
    return dir_->path() / "val_seen" /
           std::to_string(rolloutTestWorld()
                              .episodes[static_cast<size_t>(index)]
                              .episode_id);
  }

  static inline vln::test::TempDir* dir_ = nullptr;
  static inline SpyObserver* spy_ = nullptr;
  static inline rollout::EvaluationResult* result_ = nullptr;
  static inline std::vector<fs::path> folders_;
};

TEST_F(ObservationDumpTest, OnlyTheChosenEpisodesAreWrittenAndComplete) {
  EXPECT_EQ(folders_.size(), 2u);
  // the two folders and nothing else (no temporaries)
  EXPECT_EQ(vln::test::countEntries(dir_->path() / "val_seen"), 2);
  for (int i : {0, 1}) {
    const fs::path f = folder(i);
    EXPECT_TRUE(fs::exists(f / "episode.json")) << f;
    EXPECT_TRUE(fs::exists(f / "steps.jsonl")) << f;
    const size_t frames =
        result_->episodes[static_cast<size_t>(i)].record.positions.size();
    EXPECT_EQ(vln::test::countEntries(f / "rgb"), static_cast<int>(frames));
    EXPECT_EQ(vln::test::countEntries(f / "depth"), static_cast<int>(frames));
  }
  EXPECT_FALSE(fs::exists(folder(2)));
}

TEST_F(ObservationDumpTest, ImagesDecodeToTheObservations) {
  const auto& w = rolloutTestWorld();
  for (int i : {0, 1}) {
    const Seen& seen = spy_->seen.at(i);
    ASSERT_EQ(
        seen.frames.size(),
        result_->episodes[static_cast<size_t>(i)].record.positions.size());
    int validDepth = 0, invalidDepth = 0;
    for (size_t t = 0; t < seen.frames.size(); ++t) {
      const sim::Observation& obs = seen.frames[t];
      const DumpImage rgb = readDumpImage(
          folder(i) / "rgb" / frameFileName(static_cast<int>(t), "png"));
      ASSERT_EQ(rgb.channels, 3);
      ASSERT_EQ(rgb.width, 32);
      ASSERT_EQ(rgb.height, 32);
      EXPECT_EQ(rgb.rgb, obs.rgb) << "episode " << i << " frame " << t;
      const DumpImage depth = readDumpImage(
          folder(i) / "depth" / frameFileName(static_cast<int>(t), "png"));
      ASSERT_EQ(depth.channels, 1);
      ASSERT_EQ(depth.grey.size(), obs.depth.size());
      for (size_t p = 0; p < obs.depth.size(); ++p) {
        const int expected = expectedMillimetres(obs.depth[p], w.sim.depth);
        const int got = depth.grey[p];
        ASSERT_EQ(got == 0, expected == 0)
            << "episode " << i << " frame " << t << " pixel " << p;
        ASSERT_LE(std::abs(got - expected), 1)
            << "episode " << i << " frame " << t << " pixel " << p;
        ++(got ? validDepth : invalidDepth);
      }
    }
    // a house seen from inside: mostly valid depth
    EXPECT_GT(validDepth, invalidDepth);
  }
}

TEST_F(ObservationDumpTest, StepsHoldPosesActionsAndTheEpisode) {
  const auto& w = rolloutTestWorld();
  for (int i : {0, 1}) {
    const rollout::EpisodeRecord& record =
        result_->episodes[static_cast<size_t>(i)].record;
    const std::vector<nlohmann::json> steps =
        vln::test::readJsonLines(folder(i) / "steps.jsonl");
    ASSERT_EQ(steps.size(), record.positions.size());
    for (size_t t = 0; t < steps.size(); ++t) {
      const nlohmann::json& s = steps[t];
      EXPECT_EQ(s["frame"], t);
      EXPECT_EQ(s["rgb"], "rgb/" + frameFileName(static_cast<int>(t), "png"));
      for (int k = 0; k < 3; ++k)
        EXPECT_FLOAT_EQ(s["position"][k].get<float>(), record.positions[t][k]);
      EXPECT_FLOAT_EQ(s["heading"].get<float>(), record.headings[t]);
      const auto q = headingToQuaternion(record.headings[t]);
      for (int k = 0; k < 4; ++k)
        EXPECT_FLOAT_EQ(s["rotation"][k].get<float>(),
                        q[static_cast<size_t>(k)]);
      if (t + 1 < steps.size()) {
        EXPECT_EQ(s["action"], record.actions[t]);
        EXPECT_EQ(s["action_name"],
                  std::string(
                      sim::actionName(sim::actionFromInt(record.actions[t]))));
      } else {
        EXPECT_TRUE(s["action"].is_null());
      }
      EXPECT_TRUE(s["distance_to_goal"].is_number());
    }
    // the oracle stops within the follower's radius of the goal
    EXPECT_LT(steps.back()["distance_to_goal"].get<double>(), 0.5 + 1e-3);

    const auto e = common::readJsonFile(folder(i) / "episode.json");
    const data::Episode& episode = w.episodes[static_cast<size_t>(i)];
    EXPECT_EQ(e["format_version"], 1);
    EXPECT_EQ(e["split"], "val_seen");
    EXPECT_EQ(e["agent"], "oracle");
    EXPECT_EQ(e["episode_id"], episode.episode_id);
    EXPECT_EQ(e["scene_id"], episode.scene_id);
    EXPECT_EQ(e["instruction"]["text"], episode.instruction.instruction_text);
    const auto& tokens = episode.instruction.instruction_tokens;
    EXPECT_EQ(e["instruction"]["tokens"].get<std::vector<int>>(),
              std::vector<int>(tokens.begin(),
                               tokens.begin() + data::unpaddedLength(tokens)));
    EXPECT_TRUE(e["instruction"]["words"].is_null());  // no vocabulary
    EXPECT_EQ(e["num_frames"], steps.size());
    EXPECT_EQ(e["num_actions"], record.actions.size());
    EXPECT_EQ(e["called_stop"], true);
    EXPECT_EQ(e["metrics"]["success"], 1.0);
    EXPECT_EQ(e["cameras"]["depth"]["unit"], "millimetre");
    EXPECT_EQ(e["cameras"]["depth"]["max_depth"], w.sim.depth.max_depth);
    EXPECT_EQ(e["cameras"]["rgb"]["width"], 32);
  }
}

TEST_F(ObservationDumpTest, ExistingEpisodesAreNeverOverwritten) {
  DumpConfig c = dumpConfig(dir_->path());
  c.episode_ids = {rolloutTestWorld().episodes[1].episode_id};
  EXPECT_THAT(vln::test::errorOf(
                  [&] { ObservationDump(c, rolloutTestWorld().episodes); }),
              HasSubstr(folder(1).string() + "' exists already"));
}

// Chosen by id, JPEG frames; a stale temporary of a dead process goes
TEST(ObservationDumpChoiceTest, IdsAndJpegAndStaleTemporaries) {
  const auto& w = rolloutTestWorld();
  vln::test::TempDir dir;
  const fs::path stale = dir / "val_seen" / ".100.tmp.999999999.0";
  const fs::path live =
      dir / "val_seen" / (".101.tmp." + std::to_string(::getpid()) + ".0");
  fs::create_directories(stale / "rgb");
  fs::create_directories(live);
  DumpConfig c = dumpConfig(dir.path());
  c.episode_ids = {w.episodes[3].episode_id};
  c.format = "jpg";
  ObservationDump dump(c, w.episodes);
  EXPECT_FALSE(fs::exists(stale));
  EXPECT_TRUE(fs::exists(live));  // its owner runs: not stale
  fs::remove_all(live);
  EXPECT_EQ(dump.chosen(), 1);
  SpyObserver spy;
  runOracle(dump, spy, 2);
  ASSERT_EQ(dump.folders().size(), 1u);
  EXPECT_EQ(dump.folders()[0],
            dir / "val_seen" / std::to_string(w.episodes[3].episode_id));
  EXPECT_EQ(vln::test::countEntries(dir / "val_seen"), 1);
  const DumpImage rgb =
      readDumpImage(dump.folders()[0] / "rgb" / frameFileName(0, "jpg"));
  ASSERT_EQ(rgb.channels, 3);
  const std::vector<uint8_t>& shown = spy.seen.at(3).frames.front().rgb;
  ASSERT_EQ(rgb.rgb.size(), shown.size());
  double error = 0.0;
  for (size_t p = 0; p < shown.size(); ++p)
    error += std::abs(int(rgb.rgb[p]) - int(shown[p]));
  EXPECT_LT(error / static_cast<double>(shown.size()), 12.0);  // lossy
}

// An episode cut short (an exception in the evaluation) leaves no folder.
TEST(ObservationDumpChoiceTest, AnUnfinishedEpisodeLeavesNothing) {
  const auto& w = rolloutTestWorld();
  vln::test::TempDir dir;
  {
    ObservationDump dump(dumpConfig(dir.path()), w.episodes);
    rollout::VectorEnv envs(1, w.sim, w.task,
                            std::make_shared<rollout::SceneCache>(w.sim), 1);
    const std::vector<int> env = {0};
    const std::vector<const data::Episode*> episode = {&w.episodes[0]};
    envs.reset(env, episode);
    dump.episodeStarted(0, envs, 0);
    dump.episodeStepped(0, envs, 0, sim::Action::kTurnLeft);
    EXPECT_EQ(vln::test::countEntries(dir / "val_seen"), 1);  // a temporary
  }
  EXPECT_EQ(vln::test::countEntries(dir / "val_seen"), 0);
}

TEST(ObservationDumpConfigTest, BadValuesAreNamed) {
  DumpConfig c = dumpConfig("/tmp/x");
  EXPECT_NO_THROW(validate(c));
  DumpConfig format = c;
  format.format = "gif";
  EXPECT_THAT(vln::test::errorOf([&] { validate(format); }),
              HasSubstr("format must be png or jpg, got 'gif'"));
  DumpConfig quality = c;
  quality.jpeg_quality = 0;
  EXPECT_THAT(vln::test::errorOf([&] { validate(quality); }),
              HasSubstr("jpeg_quality"));
  DumpConfig first = c;
  first.first_episodes = 0;
  EXPECT_THAT(vln::test::errorOf([&] { validate(first); }),
              HasSubstr("first_episodes must be >= 1"));
  DumpConfig dir = c;
  dir.dir.clear();
  EXPECT_THAT(vln::test::errorOf([&] { validate(dir); }),
              HasSubstr("dir is empty"));
  EXPECT_EQ(frameFileName(42, "png"), "000042.png");
}

// Normalised [0, 1] over [0.5, 5] m: 0 reads 0.5 m, the far clip reads 0;
// unnormalised, what a 16-bit millimetre cannot hold reads 0 too.
TEST(ObservationDumpConfigTest, DepthMillimetresUndoTheNormalisation) {
  sim::DepthCameraConfig c;
  c.min_depth = 0.5f;
  c.max_depth = 5.0f;
  sim::Observation obs;
  obs.depth = {0.0f, 0.5f, 1.0f, 0.99999994f, 0.25f};
  EXPECT_EQ(depthMillimetres(obs, c),
            (std::vector<uint16_t>{500, 2750, 0, 0, 1625}));
  c.normalize_depth = false;
  c.min_depth = 0.0f;
  c.max_depth = 100.0f;
  obs.depth = {1.2345f, 65.0f, 70.0f, 100.0f};
  EXPECT_EQ(depthMillimetres(obs, c),
            (std::vector<uint16_t>{1235, 65000, 0, 0}));
}

TEST(ObservationDumpConfigTest, UnreadableImagesAreNamed) {
  vln::test::TempDir dir;
  vln::test::writeText(dir / "broken.png", "not a png");
  EXPECT_THAT(vln::test::errorOf([&] { readDumpImage(dir / "broken.png"); }),
              HasSubstr("broken.png"));
}

// scripts/read_observation_dump.py on a dumped episode: the same frames,
// actions and pixel sums as the C++ side, with and without numpy.
TEST(ReadObservationDumpScriptTest, ReadsTheEpisodeBack) {
  if (!fs::exists("/usr/bin/python3")) GTEST_SKIP() << "no /usr/bin/python3";
  const auto& w = rolloutTestWorld();
  vln::test::TempDir dir;
  DumpConfig c = dumpConfig(dir.path());
  c.first_episodes = 1;
  ObservationDump dump(c, w.episodes);
  SpyObserver spy;
  const rollout::EvaluationResult result = runOracle(dump, spy, 1);
  ASSERT_EQ(dump.folders().size(), 1u);

  // the sums the script must find
  int64_t rgbSum = 0, depthSum = 0;
  for (const sim::Observation& obs : spy.seen.at(0).frames) {
    for (uint8_t v : obs.rgb) rgbSum += v;
    for (uint16_t v : depthMillimetres(obs, w.sim.depth)) depthSum += v;
  }
  const size_t frames = spy.seen.at(0).frames.size();
  const bool haveNumpy =
      vln::test::runCommand("/usr/bin/python3 -c 'import numpy'") == 0;
  for (const std::string flag : {"", " --no-numpy"}) {
    SCOPED_TRACE(flag);
    std::string output;
    ASSERT_EQ(vln::test::runCommand("/usr/bin/python3 " +
                                        (vln::test::sourcePath() / "scripts" /
                                         "read_observation_dump.py")
                                            .string() +
                                        " " + dump.folders()[0].string() +
                                        flag + " 2>&1",
                                    &output),
              0)
        << output;
    const auto summary = nlohmann::json::parse(output);
    EXPECT_EQ(summary["episode_id"], w.episodes[0].episode_id);
    EXPECT_EQ(summary["num_frames"], frames);
    EXPECT_EQ(summary["actions"].get<std::vector<int>>(),
              result.episodes[0].record.actions);
    EXPECT_EQ(summary["numpy"], flag.empty() && haveNumpy);
    EXPECT_EQ(summary["rgb_shape"].get<std::vector<size_t>>(),
              (std::vector<size_t>{frames, 32, 32, 3}));
    EXPECT_EQ(summary["depth_shape"].get<std::vector<size_t>>(),
              (std::vector<size_t>{frames, 32, 32}));
    EXPECT_EQ(summary["rgb_sum"].get<int64_t>(), rgbSum);
    EXPECT_EQ(summary["depth_sum_mm"].get<int64_t>(), depthSum);
  }

  // a broken episode is an error naming the file
  vln::test::writeText(dump.folders()[0] / "depth" / frameFileName(0, "png"),
                       "garbage");
  std::string output;
  EXPECT_NE(
      vln::test::runCommand(
          "/usr/bin/python3 " +
              (vln::test::sourcePath() / "scripts" / "read_observation_dump.py")
                  .string() +
              " " + dump.folders()[0].string() + " 2>&1",
          &output),
      0);
  EXPECT_THAT(output, HasSubstr("000000.png: not a PNG file"));
}

}  // namespace
}  // namespace vln::viz
