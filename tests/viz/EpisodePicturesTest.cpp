// Episode maps and videos: written during an evaluation for the first
// episodes only, with one frame per position, the expected size, and
// content that is neither blank nor frozen.

#include "viz/EpisodePictures.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>
#include <map>

#include "rollout/Evaluator.h"
#include "rollout/RolloutTestWorld.h"

namespace vln::viz {
namespace {

namespace fs = std::filesystem;
using rollout::test::rolloutTestWorld;
using ::testing::HasSubstr;

// Replays the ground truth; reads no observations, so every rendered frame
// in a video was asked for by the observer.
class ReplayAgent : public rollout::Agent {
 public:
  void reset(int env, const data::Episode& episode) override {
    cursor_[env] = {episode.episode_id, 0};
  }
  std::vector<sim::Action> act(rollout::VectorEnv&,
                               std::span<const int> active) override {
    std::vector<sim::Action> actions;
    for (int env : active) {
      auto& [id, step] = cursor_.at(env);
      actions.push_back(rolloutTestWorld().groundTruth.at(id).actions.at(
          static_cast<size_t>(step++)));
    }
    return actions;
  }
  bool needsObservations() const override { return false; }

 private:
  std::map<int, std::pair<int, int>> cursor_;
};

// width and height of a PNG from its IHDR chunk
std::pair<int, int> pngSize(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::vector<unsigned char> head(24);
  in.read(reinterpret_cast<char*>(head.data()), 24);
  EXPECT_EQ(std::string(head.begin() + 1, head.begin() + 4), "PNG");
  auto be32 = [&](int at) {
    return (head[at] << 24) | (head[at + 1] << 16) | (head[at + 2] << 8) |
           head[at + 3];
  };
  return {be32(16), be32(20)};
}

rollout::EvaluationResult evaluateWith(EpisodePictures& pictures, int numEnvs) {
  const auto& w = rolloutTestWorld();
  ReplayAgent agent;
  rollout::VectorEnv envs(numEnvs, w.sim, w.task,
                          std::make_shared<rollout::SceneCache>(w.sim), 2);
  return rollout::evaluateEpisodes(agent, envs, w.episodes, &w.groundTruth,
                                   rollout::EvalConfig{}, {}, &pictures);
}

TEST(EpisodePicturesTest, MapsAndVideosForTheFirstEpisodesDuringEvaluation) {
  const auto& w = rolloutTestWorld();
  vln::test::TempDir dir;
  for (const std::string format : {"avi", "mp4"}) {
    SCOPED_TRACE(format);
    PicturesConfig config;
    config.dir = dir / format;
    config.prefix = "ckpt_2_val_seen_";
    config.map_episodes = 3;
    config.video_episodes = 2;
    config.video_format = format;
    config.video_height = 64;
    EpisodePictures pictures(config);
    const rollout::EvaluationResult r = evaluateWith(pictures, /*numEnvs=*/3);

    // maps of episodes 0-2, videos of episodes 0-1, nothing else
    std::set<std::string> names;
    for (const auto& entry : fs::directory_iterator(config.dir))
      names.insert(entry.path().filename().string());
    std::set<std::string> expected;
    for (int i = 0; i < 3; ++i)
      expected.insert(mapFileName(
          config.prefix,
          std::to_string(w.episodes[static_cast<size_t>(i)].episode_id)));
    for (int i = 0; i < 2; ++i)
      expected.insert(videoFileName(
          config.prefix,
          std::to_string(w.episodes[static_cast<size_t>(i)].episode_id),
          format));
    EXPECT_EQ(names, expected);
    EXPECT_EQ(pictures.files().size(), 5u);

    // maps 1,024 px on the long side over their legend footer
    const float y0 = w.episodes[0].start_position.y();
    const sim::TopDownMap full(*w.scene,
                               MapStyle{}.metersPerPixel(*w.scene, y0), y0);
    EXPECT_EQ(std::max(full.width(), full.height()), 1024);
    const auto [mapWidth, mapHeight] = pngSize(
        config.dir /
        mapFileName(config.prefix, std::to_string(w.episodes[0].episode_id)));
    EXPECT_EQ(mapWidth, full.width());
    EXPECT_EQ(mapHeight,
              full.height() + footerHeight(full.width(), full.metersPerPixel(),
                                           MapLegend{}));
    // the video's map panel: drawn at twice the panel height at most
    const sim::TopDownMap reference(
        *w.scene, MapStyle{.long_side = 128}.metersPerPixel(*w.scene, y0), y0);

    for (int i = 0; i < 2; ++i) {
      const auto& record = r.episodes[static_cast<size_t>(i)].record;
      const VideoSummary v = summarizeVideo(
          config.dir / videoFileName(config.prefix, record.episode_id, format));
      // a frame after reset and after every action
      EXPECT_EQ(v.frames, record.steps_taken + 1);
      // panels 64 px high (RGB and depth 64 wide, the map keeps its
      // aspect, rounded up to 8 px) over the 48 px caption band; sizes in
      // multiples of 8 (OpenCV's MJPEG encoder corrupts other widths)
      EXPECT_EQ(v.height, 64 + 48);
      const double expectedMap = 64.0 * reference.width() / reference.height();
      EXPECT_GE(v.width, 64 + 64 + expectedMap - 0.5);
      EXPECT_LT(v.width, 64 + 64 + expectedMap + 8);
      EXPECT_EQ(v.width % 8, 0);
      EXPECT_GT(v.first_frame_stddev, 20.0);  // not blank
      // frames change as the agent moves
      const auto [lo, hi] =
          std::minmax_element(v.frame_means.begin(), v.frame_means.end());
      EXPECT_GT(*hi - *lo, 1.0);
    }
  }
}

TEST(EpisodePicturesTest, VideoOfATestEpisodeWithoutGoal) {
  const auto& w = rolloutTestWorld();
  vln::test::TempDir dir;
  PicturesConfig config;
  config.dir = dir.path();
  config.video_episodes = 1;
  config.video_height = 32;
  data::Episode episode = w.episodes[1];
  episode.goals.clear();
  EpisodeVideo video(dir / "v.avi", config, *w.scene, episode, {}, 32, 32, 32,
                     32, 1.0f);
  sim::Simulator simulator(w.scene, w.sim, w.task);
  simulator.reset({episode.start_position, episode.startHeading()});
  sim::Observation obs;
  simulator.observe(obs);
  video.addFrame(obs, simulator.episode().agent, 0, nullptr, -1.0f);
  for (sim::Action a : w.groundTruth.at(episode.episode_id).actions) {
    simulator.step(a);
    simulator.observe(obs);
    video.addFrame(obs, simulator.episode().agent, simulator.episode().steps,
                   &a, -1.0f);
  }
  EXPECT_FALSE(fs::exists(dir / "v.avi"));  // still under its partial name
  video.close();
  EXPECT_TRUE(fs::exists(dir / "v.avi"));
  EXPECT_FALSE(fs::exists(dir / "v.partial.avi"));
  EXPECT_EQ(summarizeVideo(dir / "v.avi").frames, video.frames());
  EXPECT_THAT(
      [&] {
        video.addFrame(obs, simulator.episode().agent, 0, nullptr, -1.0f);
      },
      ::testing::Throws<std::invalid_argument>(::testing::Property(
          &std::exception::what, HasSubstr("is already closed"))));

  // a frame of the wrong size is refused, naming the file
  EpisodeVideo other(dir / "w.avi", config, *w.scene, episode, {}, 16, 16, 16,
                     16, 1.0f);
  EXPECT_THAT(
      [&] {
        other.addFrame(obs, simulator.episode().agent, 0, nullptr, -1.0f);
      },
      ::testing::Throws<std::invalid_argument>(::testing::Property(
          &std::exception::what,
          HasSubstr("w.avi': observation is RGB 32x32, depth 32x32"))));
}

TEST(EpisodePicturesTest, AnAbandonedVideoLeavesNoFile) {
  const auto& w = rolloutTestWorld();
  vln::test::TempDir dir;
  PicturesConfig config;
  config.video_height = 32;
  {
    EpisodeVideo video(dir / "gone.avi", config, *w.scene, w.episodes[0], {},
                       32, 32, 32, 32, 1.0f);
    EXPECT_TRUE(fs::exists(dir / "gone.partial.avi"));
  }
  EXPECT_FALSE(fs::exists(dir / "gone.partial.avi"));
  EXPECT_FALSE(fs::exists(dir / "gone.avi"));
  config.video_format = "gif";
  EXPECT_THROW(EpisodePictures{config}, std::invalid_argument);
  EXPECT_THROW(summarizeVideo(dir / "none.avi"), std::runtime_error);
}

}  // namespace
}  // namespace vln::viz
