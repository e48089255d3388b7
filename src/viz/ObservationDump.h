#pragma once
// Observation dumps: what an agent saw and did, step by step, for models
// trained outside this project (video-language agents such as NaVid and
// StreamVLN train on such dumps; VLN-CE issue #66). An EpisodeObserver, so
// any agent that runs through rollout::evaluateEpisodes() can be dumped,
// the oracle included (`eval --agent oracle --dump DIR`).
//
// Layout (docs/dumps.md has the full description and a Python reader,
// scripts/read_observation_dump.py):
//
//   <dir>/<split>/<episode_id>/
//     episode.json        the episode (instruction text, tokens and their
//                         words when the vocabulary is known, start,
//                         goals, reference path), the agent, the cameras,
//                         the frame count and, with goals, the metrics
//     steps.jsonl         one JSON object per frame t = 0..T (T actions):
//                         pose, the action taken at that frame (null at the
//                         last), the collision flag of the move that led to
//                         it and the geodesic distance to the goal
//     rgb/000000.png      frame t's RGB, 8-bit sRGB (or .jpg)
//     depth/000000.png    frame t's depth, 16-bit grey PNG, millimetres
//
// Frame 0 is the observation after reset, frame t + 1 the one after the
// t-th action, so frame t with its "action" is the (observation, action)
// pair a policy sees. Poses are the agent's: `position` its feet on the
// navmesh in the world frame (Y up, metres; the cameras sit
// sim.rgb.position_y / sim.depth.position_y above it), `heading` radians
// about +Y (0 looks along -Z, counter-clockwise positive: common/Math.h),
// `rotation` the same yaw as Habitat's quaternion in the R2R_VLNCE file
// order [x, y, z, w] (the body's; Habitat keeps the sensors' tilt apart).
// In RxR's action space (sim.agent.look_actions) a frame also has `pitch`,
// the cameras' tilt in radians about their +X axis, positive up.
//
// Depth: the simulator clips depth to [min_depth, max_depth]
// (sim.depth.min_depth / max_depth, metres; misses read as max_depth) and
// may normalise it to [0, 1]; the dump undoes the normalisation and stores
// round(metres * 1000). A pixel at max_depth (beyond the range or a miss;
// the two cannot be told apart) or beyond 65.535 m is 0, "no valid depth";
// a pixel nearer than min_depth reads min_depth.
//
// An episode's folder is written under a temporary name, made durable with
// one sync when the episode ends (common::writeFileUnsynced() and
// syncFileSystem(): one fsync per file, as writeFileAtomic() does, made a
// dump 16 times slower) and only then renamed into place, so it is either
// complete or absent; temporaries left by a killed process are removed by
// the next dump into the same split folder. Existing episode
// folders are never overwritten (construction fails naming the first one).

#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <set>
#include <span>
#include <string>
#include <vector>

#include "data/Episode.h"
#include "data/Vocabulary.h"
#include "rollout/Evaluator.h"
#include "sim/SimConfig.h"
#include "sim/Simulator.h"

namespace vln::viz {

/// What is dumped and where.
struct DumpConfig {
  /// Root directory; episodes go to <dir>/<split>/<episode_id>/.
  std::filesystem::path dir;
  /// Split name (the folder under `dir`).
  std::string split;
  /// Dump the episodes at input positions < first_episodes (-1: all);
  /// ignored when `episode_ids` is not empty.
  int first_episodes = -1;
  /// Dump exactly these episode ids (those among the input episodes).
  std::vector<int> episode_ids;
  /// RGB image format: "png" (lossless) or "jpg".
  std::string format = "png";
  /// JPEG quality 1-100 for format "jpg".
  int jpeg_quality = 95;
  /// The cameras of the run (sim.rgb, sim.depth): written to episode.json;
  /// the depth camera's clipping and normalisation are undone.
  sim::CameraConfig rgb;
  sim::DepthCameraConfig depth;
  /// What acted, written to episode.json (e.g. "oracle", "ckpt.3.pth").
  std::string agent;
  /// The dataset's instruction vocabulary (data::Split::vocabulary), to
  /// write the tokens' words too; may be null (must outlive the dump).
  const data::Vocabulary* vocabulary = nullptr;
};

/// Throws std::invalid_argument naming the field when `config` is invalid:
/// empty dir or split, format other than png / jpg, jpeg_quality outside
/// 1-100, first_episodes < -1 or 0.
void validate(const DumpConfig& config);

/// File name of frame `frame` of an image folder: "000042.<extension>".
std::string frameFileName(int frame, const std::string& extension);

/// The depth of `observation` (post-processed per `depth`) as millimetres
/// [depth_height, depth_width] row-major: round(metres * 1000), 0 where the
/// depth is at max_depth (beyond range or no hit) or beyond 65.535 m.
std::vector<uint16_t> depthMillimetres(const sim::Observation& observation,
                                       const sim::DepthCameraConfig& depth);

/// An image read back from a dump (for checks and C++ readers).
struct DumpImage {
  int width = 0;
  int height = 0;
  /// 3: 8-bit RGB in `rgb` [height, width, 3]; 1: 16-bit grey in `grey`
  /// [height, width].
  int channels = 0;
  std::vector<uint8_t> rgb;
  std::vector<uint16_t> grey;
};

/// Decodes a dumped PNG or JPEG (8-bit RGB or 16-bit grey). Throws
/// std::runtime_error naming the file when it cannot be read or decoded, or
/// holds another pixel type.
DumpImage readDumpImage(const std::filesystem::path& file);

/// The rollout::EpisodeObserver that writes the dump of the chosen
/// episodes while an evaluation runs. Frames are encoded and written as
/// they come (memory holds one episode's step records per environment).
class ObservationDump : public rollout::EpisodeObserver {
 public:
  /// Dumps episodes of `episodes` (the evaluated list, in its order;
  /// referenced, must outlive this). Validates `config`, removes stale
  /// temporaries of dead processes from <dir>/<split>, and throws
  /// std::invalid_argument naming the folder when a chosen episode's
  /// folder exists already.
  ObservationDump(DumpConfig config,
                  const std::vector<data::Episode>& episodes);
  ~ObservationDump() override;

  bool wantsFrames(int index) const override;
  void episodeStarted(int index, rollout::VectorEnv& envs, int env) override;
  void episodeStepped(int index, rollout::VectorEnv& envs, int env,
                      sim::Action action) override;
  void episodeFinished(int index, rollout::VectorEnv& envs, int env,
                       const rollout::EpisodeResult& result,
                       bool scored) override;

  /// Number of input episodes chosen for dumping.
  int chosen() const { return static_cast<int>(chosen_.size()); }
  /// Episode folders completed so far, in completion order.
  const std::vector<std::filesystem::path>& folders() const { return folders_; }
  /// The folder of episode `episodeId`: <dir>/<split>/<episodeId>.
  std::filesystem::path episodeFolder(int episodeId) const;

 private:
  struct InProgress;
  // writes frame `frame` of `env`'s episode (images and its step record)
  void writeFrame(InProgress& episode, rollout::VectorEnv& envs, int env);

  DumpConfig config_;
  const std::vector<data::Episode>& episodes_;
  std::set<int> chosen_;                                ///< input positions
  std::map<int, std::unique_ptr<InProgress>> running_;  ///< by environment
  std::vector<std::filesystem::path> folders_;
};

}  // namespace vln::viz
