#pragma once
// Pictures of evaluated episodes, like the paper's qualitative figure:
//  - a top-down map PNG (viz/EpisodeMap.h) with the reference path (blue),
//    the agent's path (orange), the start (green), the goal (red) and the
//    3 m success circle around it, the agent's final pose, a legend and a
//    scale bar;
//  - a video of the episode, one frame after reset and one per action:
//    egocentric RGB | depth | the top-down map with the path so far, over a
//    caption band (instruction, step, action, distance to the goal).
// Videos are MJPG in .avi or mp4v in .mp4, both written through OpenCV's
// FFmpeg backend (Debian's libopencv-videoio links libavcodec, so no extra
// codec is needed); OpenCV's built-in MJPEG encoder is the .avi fallback.
// Frames go to the encoder as they are captured, so memory stays bounded by the
// number of videos in progress (at most one per environment); each file is
// written under a temporary name and renamed when complete.

#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "data/Episode.h"
#include "rollout/Evaluator.h"
#include "rollout/Metrics.h"
#include "sim/Scene.h"
#include "sim/Simulator.h"
#include "sim/TopDownMap.h"
#include "viz/EpisodeMap.h"

namespace vln::viz {

/// What is drawn and where.
struct PicturesConfig {
  /// Output directory (created on demand).
  std::filesystem::path dir;
  /// Prefix of every file name, e.g. "ckpt_3_val_seen_".
  std::string prefix;
  /// Maps for the episodes at input positions < map_episodes.
  int map_episodes = 0;
  /// Videos for the episodes at input positions < video_episodes.
  int video_episodes = 0;
  /// "avi" (MJPG) or "mp4" (mp4v).
  std::string video_format = "avi";
  /// Height of each video panel, pixels, rounded up to a multiple of 8
  /// (observations are scaled to it; the frame is three panels side by
  /// side over a 48 px caption band, every size a multiple of 8).
  int video_height = 256;
  /// Video frame rate (frames per second; one frame per action).
  double fps = 4.0;
  /// Map size (1,024 pixels on the long side unless a scale is set); the
  /// video's map panel is drawn at twice the panel height at most.
  MapStyle map;
  /// Success radius drawn around the goal, metres (VLN-CE: 3 m).
  float success_distance = 3.0f;
};

/// File name of its video: "<prefix>episode_<id>.<format>".
std::string videoFileName(const std::string& prefix,
                          const std::string& episodeId,
                          const std::string& format);

/// One episode's video being written.
class EpisodeVideo {
 public:
  /// Opens `file` (format from config.video_format) for an episode in
  /// `scene` whose observations are `rgbWidth` x `rgbHeight` (RGB) and
  /// `depthWidth` x `depthHeight` (depth); draws the reference path, start,
  /// goal and success circle (goal only when it has one) on the map. Depth
  /// values are shown as grey levels of value / `depthScale`. Throws
  /// std::runtime_error naming the file when the writer cannot open.
  EpisodeVideo(const std::filesystem::path& file, const PicturesConfig& config,
               const sim::Scene& scene, const data::Episode& episode,
               const std::vector<Vec3f>& reference, int rgbWidth, int rgbHeight,
               int depthWidth, int depthHeight, float depthScale);
  ~EpisodeVideo();
  EpisodeVideo(const EpisodeVideo&) = delete;
  EpisodeVideo& operator=(const EpisodeVideo&) = delete;

  /// Appends a frame: the observation, the agent at `pose` with its path
  /// extended to it, and a caption ("step k: ACTION", distance to goal when
  /// `distanceToGoal` >= 0). `action` is the action just taken (none on the
  /// first frame).
  void addFrame(const sim::Observation& observation,
                const sim::AgentState& pose, int step,
                const sim::Action* action, float distanceToGoal);
  /// Finishes the file (renamed into place). Further frames are an error.
  void close();
  /// Frames written so far.
  int frames() const { return frames_; }
  /// Frame size in pixels.
  int width() const;
  int height() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  int frames_ = 0;
};

/// What a written video holds (decoded back with OpenCV), for checks and
/// reports.
struct VideoSummary {
  int frames = 0;
  int width = 0;
  int height = 0;
  /// Mean grey level (0-255) of each frame.
  std::vector<double> frame_means;
  /// Standard deviation of the grey levels of the first frame.
  double first_frame_stddev = 0.0;
};

/// Decodes `file` (.avi or .mp4) frame by frame. Throws std::runtime_error
/// naming the file when it cannot be opened or holds no frame.
VideoSummary summarizeVideo(const std::filesystem::path& file);

/// The rollout::EpisodeObserver that writes maps and videos during an
/// evaluation.
class EpisodePictures : public rollout::EpisodeObserver {
 public:
  explicit EpisodePictures(PicturesConfig config);
  ~EpisodePictures() override;

  bool wantsFrames(int index) const override;
  void episodeStarted(int index, rollout::VectorEnv& envs, int env) override;
  void episodeStepped(int index, rollout::VectorEnv& envs, int env,
                      sim::Action action) override;
  void episodeFinished(int index, rollout::VectorEnv& envs, int env,
                       const rollout::EpisodeResult& result,
                       bool scored) override;

  /// Files written so far, in the order they were completed.
  const std::vector<std::filesystem::path>& files() const { return files_; }

 private:
  PicturesConfig config_;
  std::map<int, std::unique_ptr<EpisodeVideo>> videos_;  ///< by environment
  std::vector<std::filesystem::path> files_;
};

}  // namespace vln::viz
