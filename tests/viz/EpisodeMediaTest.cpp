// Tests of src/viz/EpisodeMedia.cpp on the rollout test house: maps (PNG,
// exactly the pixels of mapPicture(drawEpisodeMap())) and videos (GIF: one
// frame per position, the egocentric RGB panel equal to the observation the
// agent saw, the usual delay and a held last frame) for the first episodes
// only; no frames asked for when no video is; bad settings; and the sizes of a
// 120-step video and of a map (printed, for docs/paper_scale.md).

#include "viz/EpisodeMedia.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <iostream>
#include <map>

#include "rollout/Evaluator.h"
#include "rollout/RolloutTestWorld.h"
#include "support/GifDecoder.h"
#include "viz/EpisodeMap.h"
#include "viz/Gif.h"
#include "viz/Image.h"

namespace vln::viz {
namespace {

using rollout::test::rolloutTestWorld;
using ::testing::HasSubstr;

// Replays the follower's ground truth and keeps every RGB observation it
// is shown, by episode id (frame k of a video is the observation before
// action k).
class ObservingReplayAgent : public rollout::Agent {
 public:
  explicit ObservingReplayAgent(bool observes) : observes_(observes) {}
  void reset(int env, const data::Episode& episode) override {
    cursor_[env] = {episode.episode_id, 0};
  }
  std::vector<sim::Action> act(rollout::VectorEnv& envs,
                               std::span<const int> active) override {
    std::vector<sim::Action> actions;
    for (int env : active) {
      auto& [id, step] = cursor_.at(env);
      const sim::Observation& observation = envs.observation(env);
      if (observes_) seen[id].push_back(observation.rgb);
      rendered = rendered || !observation.rgb.empty();
      actions.push_back(rolloutTestWorld().groundTruth.at(id).actions.at(
          static_cast<size_t>(step++)));
    }
    return actions;
  }
  bool needsObservations() const override { return observes_; }

  std::map<int, std::vector<std::vector<uint8_t>>> seen;
  bool rendered = false;  ///< any observation was rendered

 private:
  bool observes_;
  std::map<int, std::pair<int, int>> cursor_;
};

// Walks forward, turning left after every third step, and never stops.
class WanderAgent : public rollout::Agent {
 public:
  void reset(int env, const data::Episode&) override { steps_[env] = 0; }
  std::vector<sim::Action> act(rollout::VectorEnv&,
                               std::span<const int> active) override {
    std::vector<sim::Action> actions;
    for (int env : active)
      actions.push_back(++steps_[env] % 4 == 0 ? sim::Action::kTurnLeft
                                               : sim::Action::kMoveForward);
    return actions;
  }

 private:
  std::map<int, int> steps_;
};

MediaConfig counts(int maps, int videos) {
  MediaConfig config;
  config.maps = maps;
  config.videos = videos;
  return config;
}

rollout::EvaluationResult evaluate(rollout::Agent& agent, EpisodeMedia& media,
                                   int numEnvs) {
  const auto& w = rolloutTestWorld();
  rollout::VectorEnv envs(numEnvs, w.sim, w.task,
                          std::make_shared<rollout::SceneCache>(w.sim), 2);
  return rollout::evaluateEpisodes(agent, envs, w.episodes, &w.groundTruth,
                                   rollout::EvalConfig{}, {}, &media);
}

TEST(EpisodeMediaTest, MapsAndVideosOfTheFirstEpisodes) {
  const auto& w = rolloutTestWorld();
  MediaConfig config;
  config.maps = 3;
  config.videos = 2;
  config.video_height = 96;  // 3x the test world's 32 px cameras
  config.fps = 4.0;
  config.hold_last_seconds = 1.5;
  EpisodeMedia media(config);
  EXPECT_TRUE(media.wantsFrames(1));
  EXPECT_FALSE(media.wantsFrames(2));
  ObservingReplayAgent agent(/*observes=*/true);
  const rollout::EvaluationResult result = evaluate(agent, media, 3);

  const std::vector<EpisodeMediaItem> items = media.take();
  EXPECT_TRUE(media.take().empty());  // taken
  ASSERT_EQ(items.size(), 5u);
  // maps first, then videos, each in input order
  for (int i = 0; i < 5; ++i) {
    const EpisodeMediaItem& item = items[static_cast<size_t>(i)];
    const int index = i < 3 ? i : i - 3;
    EXPECT_EQ(item.kind, i < 3 ? EpisodeMediaItem::Kind::kMap
                               : EpisodeMediaItem::Kind::kVideo);
    EXPECT_EQ(item.index, index);
    EXPECT_EQ(
        item.episode_id,
        std::to_string(w.episodes[static_cast<size_t>(index)].episode_id));
    EXPECT_EQ(item.channels, 3);
  }
  EXPECT_STREQ(mediaKindName(items[0].kind), "map");
  EXPECT_STREQ(mediaKindName(items[3].kind), "video");

  // a map is the map picture (legend and scale bar included), losslessly
  for (int i = 0; i < 3; ++i) {
    const EpisodeMediaItem& item = items[static_cast<size_t>(i)];
    const sim::TopDownMap map =
        drawEpisodeMap(*w.scene, result.episodes[static_cast<size_t>(i)].record,
                       /*hasGoal=*/true, config.success_distance, config.map);
    EXPECT_EQ(std::max(map.width(), map.height()), 1024);
    const Image expected =
        mapPicture(map, MapLegend{true, config.success_distance, true});
    const Image png = decodePng(item.encoded);
    EXPECT_EQ(png.width, expected.width);
    EXPECT_EQ(png.height, expected.height);
    EXPECT_EQ(item.width, expected.width);
    EXPECT_EQ(item.height, expected.height);
    EXPECT_EQ(item.frames, 1);
    EXPECT_EQ(png.rgb, expected.rgb);
  }

  for (int i = 0; i < 2; ++i) {
    SCOPED_TRACE(i);
    const EpisodeMediaItem& item = items[static_cast<size_t>(3 + i)];
    const rollout::EpisodeRecord& record =
        result.episodes[static_cast<size_t>(i)].record;
    const test::DecodedGif gif = test::decodeGif(item.encoded);
    // a frame after reset and after every action; RGB, depth and map panels
    // 96 px high over the 14 px caption
    ASSERT_EQ(static_cast<int>(gif.frames.size()), record.steps_taken + 1);
    EXPECT_EQ(item.frames, record.steps_taken + 1);
    EXPECT_EQ(gif.width, item.width);
    EXPECT_EQ(gif.height, item.height);
    EXPECT_EQ(item.height, 96 + 14);
    EXPECT_GT(item.width, 96 + 96);
    EXPECT_LE(item.width, 96 + 96 + 3 * 96);
    EXPECT_EQ(gif.loop_count, 0);
    for (size_t f = 0; f + 1 < gif.frames.size(); ++f)
      ASSERT_EQ(gif.frames[f].delay_cs, 25);  // 4 fps
    EXPECT_EQ(gif.frames.back().delay_cs, 150);

    // the RGB panel is the observation scaled 3x (nearest) in palette
    // colours: pixel (3x + 1, 3y + 1) shows observation pixel (x, y)
    const auto& seen = agent.seen.at(std::stoi(item.episode_id));
    ASSERT_EQ(static_cast<int>(seen.size()), record.steps_taken);
    for (size_t f = 0; f < seen.size(); ++f) {
      const std::vector<uint8_t>& observation = seen[f];
      const std::vector<uint8_t>& frame = gif.frames[f].rgb;
      for (int y = 0; y < 32; ++y)
        for (int x = 0; x < 32; ++x) {
          const size_t o = (static_cast<size_t>(y) * 32 + x) * 3;
          const auto& expected = gifPalette()[nearestGifColor(
              observation[o], observation[o + 1], observation[o + 2])];
          const size_t p =
              ((static_cast<size_t>(3 * y + 1)) * gif.width + 3 * x + 1) * 3;
          ASSERT_EQ(frame[p], expected[0]) << "frame " << f;
          ASSERT_EQ(frame[p + 1], expected[1]) << "frame " << f;
          ASSERT_EQ(frame[p + 2], expected[2]) << "frame " << f;
        }
    }
    // the depth panel is grey; the map panel gains the agent's path
    const auto& first = gif.frames.front().rgb;
    const size_t depthPixel = (48 * static_cast<size_t>(gif.width) + 144) * 3;
    EXPECT_EQ(first[depthPixel], first[depthPixel + 1]);
    EXPECT_EQ(first[depthPixel + 1], first[depthPixel + 2]);
    int mapChanges = 0;
    const auto& last = gif.frames.back().rgb;
    for (int y = 0; y < 96; ++y)
      for (int x = 192; x < gif.width; ++x) {
        const size_t p = (static_cast<size_t>(y) * gif.width + x) * 3;
        mapChanges += first[p] != last[p] || first[p + 1] != last[p + 1];
      }
    EXPECT_GT(mapChanges, 10);
  }
}

TEST(EpisodeMediaTest, OnlyMapsAskForNoFrames) {
  MediaConfig config;
  config.maps = 2;
  config.videos = 0;
  EpisodeMedia media(config);
  for (int i = 0; i < 10; ++i) EXPECT_FALSE(media.wantsFrames(i));
  // an agent that reads no observations: none is rendered for the maps
  ObservingReplayAgent agent(/*observes=*/false);
  evaluate(agent, media, 2);
  EXPECT_FALSE(agent.rendered);
  const std::vector<EpisodeMediaItem> items = media.take();
  ASSERT_EQ(items.size(), 2u);
  EXPECT_EQ(items[0].kind, EpisodeMediaItem::Kind::kMap);
  EXPECT_EQ(items[1].index, 1);

  EpisodeMedia none(counts(/*maps=*/0, /*videos=*/0));
  ObservingReplayAgent blind(/*observes=*/false);
  evaluate(blind, none, 2);
  EXPECT_FALSE(blind.rendered);
  EXPECT_TRUE(none.take().empty());
}

TEST(EpisodeMediaTest, BadSettingsAreErrors) {
  EXPECT_THAT(
      [] { EpisodeMedia(counts(/*maps=*/-1, /*videos=*/0)); },
      ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("maps -1")));
  EXPECT_THAT(
      [] {
        MediaConfig config = counts(0, 1);
        config.video_height = 8;
        EpisodeMedia{config};
      },
      ::testing::ThrowsMessage<std::invalid_argument>(
          HasSubstr("video height")));
  EXPECT_THAT(
      [] {
        MediaConfig config;
        config.fps = 0.0;
        EpisodeMedia{config};
      },
      ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("fps")));
}

// The sizes docs/paper_scale.md quotes: the main job's 64x64 cameras, a
// 120-step episode (the agent never stops), the default 96 px panels.
TEST(EpisodeMediaTest, SizeOfA120StepVideoAndAMap) {
  const auto& w = rolloutTestWorld();
  sim::SimConfig sim = w.sim;
  sim.rgb.width = sim.rgb.height = 64;
  sim.depth.camera.width = sim.depth.camera.height = 64;
  sim::TaskConfig task = w.task;
  task.max_episode_steps = 120;
  EpisodeMedia media(counts(/*maps=*/1, /*videos=*/1));
  WanderAgent agent;
  rollout::VectorEnv envs(1, sim, task,
                          std::make_shared<rollout::SceneCache>(sim), 1);
  const std::vector<data::Episode> one = {w.episodes[0]};
  const rollout::EvaluationResult result = rollout::evaluateEpisodes(
      agent, envs, one, &w.groundTruth, rollout::EvalConfig{}, {}, &media);
  ASSERT_EQ(result.episodes[0].record.steps_taken, 120);
  const std::vector<EpisodeMediaItem> items = media.take();
  ASSERT_EQ(items.size(), 2u);
  const EpisodeMediaItem& map = items[0];
  const EpisodeMediaItem& video = items[1];
  EXPECT_EQ(video.frames, 121);
  EXPECT_EQ(test::decodeGif(video.encoded).frames.size(), 121u);
  std::cout << "map PNG: " << map.width << "x" << map.height << ", "
            << map.encoded.size() << " bytes\n"
            << "120-step video GIF: " << video.width << "x" << video.height
            << ", " << video.frames << " frames, " << video.encoded.size()
            << " bytes\n";
  RecordProperty("map_png_bytes", static_cast<int>(map.encoded.size()));
  RecordProperty("video_gif_bytes", static_cast<int>(video.encoded.size()));
  // "a few hundred kilobytes" (EpisodeMedia.h)
  EXPECT_LT(video.encoded.size(), 1000u * 1000u);
}

}  // namespace
}  // namespace vln::viz
