#pragma once
// Pictures of evaluated episodes kept in memory, encoded, for TensorBoard
// (the trainer's periodic evaluation writes them as image summaries, as
// VLN-CE's VIDEO_OPTION: [tensorboard] does):
//  - the top-down map of the first `maps` episodes as PNG: the picture of
//    viz/EpisodeMap.h (reference and agent paths, start, goal, success
//    circle, final pose, legend and scale bar), as `eval --maps` writes;
//  - a video of the first `videos` episodes as an animated GIF (Gif.h), one
//    frame after reset and one per action: egocentric RGB | depth | the map
//    with the agent's path so far, over a one-line caption (step, action,
//    geodesic distance to the goal), downscaled to `video_height` pixels so
//    that a 120-step episode stays a few hundred kilobytes. The map panel
//    is drawEpisodeMap() of the start (whose heading stays as an arrow) at
//    twice the panel height at most, scaled into the panel; the agent's
//    path and pose are drawn on the panel. The last frame is held for
//    `hold_last_seconds` before the GIF loops.
// Frames are compressed as they arrive, so memory holds at most one GIF in
// progress per environment plus the finished media. With maps = videos = 0
// the observer asks for no frames and draws nothing.

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "rollout/Evaluator.h"
#include "viz/EpisodeMap.h"

namespace vln::viz {

/// What is drawn.
struct MediaConfig {
  /// Maps of the episodes at input positions < maps.
  int maps = 2;
  /// Videos of the episodes at input positions < videos.
  int videos = 0;
  /// Height of each video panel (RGB, depth, map), pixels (>= 16); the
  /// frame adds a 14 px caption band.
  int video_height = 96;
  /// Frames per second of the videos (one frame per action), in (0, 100].
  double fps = 4.0;
  /// How long the last frame stays before the GIF loops, seconds.
  double hold_last_seconds = 1.5;
  /// Map size (1,024 pixels on the long side unless a scale is set); the
  /// video's map is drawn at twice the panel height at most.
  MapStyle map;
  /// Success radius drawn around the goal, metres (VLN-CE: 3 m).
  float success_distance = 3.0f;
};

/// One encoded picture or video of an episode.
struct EpisodeMediaItem {
  enum class Kind { kMap, kVideo };
  Kind kind = Kind::kMap;
  /// Position of the episode in the evaluated list.
  int index = 0;
  std::string episode_id;
  /// PNG (map) or GIF (video) bytes.
  std::string encoded;
  /// Size in pixels (a map's includes its legend footer).
  int width = 0;
  int height = 0;
  int channels = 3;  ///< RGB
  int frames = 1;    ///< 1 for a map
};

/// "map" or "video".
const char* mediaKindName(EpisodeMediaItem::Kind kind);

/// The rollout::EpisodeObserver that draws and encodes the media of an
/// evaluation.
class EpisodeMedia : public rollout::EpisodeObserver {
 public:
  /// Throws std::invalid_argument for negative counts, a video height below
  /// 16 or an fps outside (0, 100].
  explicit EpisodeMedia(MediaConfig config);
  ~EpisodeMedia() override;

  bool wantsFrames(int index) const override;
  void episodeStarted(int index, rollout::VectorEnv& envs, int env) override;
  void episodeStepped(int index, rollout::VectorEnv& envs, int env,
                      sim::Action action) override;
  void episodeFinished(int index, rollout::VectorEnv& envs, int env,
                       const rollout::EpisodeResult& result,
                       bool scored) override;

  /// The media finished so far, maps first, each kind in input order; the
  /// observer keeps none of them afterwards.
  std::vector<EpisodeMediaItem> take();

 private:
  class Video;
  MediaConfig config_;
  std::map<int, std::unique_ptr<Video>> videos_;  ///< by environment
  std::vector<EpisodeMediaItem> items_;
};

}  // namespace vln::viz
