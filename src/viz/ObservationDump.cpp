#include "viz/ObservationDump.h"

#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "common/Check.h"
#include "common/FileIo.h"
#include "common/Json.h"
#include "data/Vocabulary.h"
#include "rollout/VectorEnv.h"

namespace vln::viz {
namespace fs = std::filesystem;

namespace {

// Version of the layout in ObservationDump.h, written to episode.json.
constexpr int kFormatVersion = 1;

// A depth within this of max_depth (metres) is "beyond range": half a
// millimetre, the rounding of the stored value, absorbs the float error of
// undoing the normalisation.
constexpr float kMaxDepthTolerance = 0.0005f;

// Largest depth a 16-bit millimetre value holds, metres.
constexpr float kMaxStorableDepth = 65.535f;

nlohmann::json vec3(const Vec3f& v) { return {v.x(), v.y(), v.z()}; }

// "<id>.tmp.<pid>.<n>": a folder being written by process <pid>
std::string temporaryName(int episodeId) {
  static std::atomic<uint64_t> counter{0};
  // appended rather than "." + to_string(): GCC 12 at -O3 warns falsely
  // (stringop-overflow) about the operator+ form
  std::string name = ".";
  name += std::to_string(episodeId);
  name += ".tmp.";
  name += std::to_string(::getpid());
  name += ".";
  name += std::to_string(counter++);
  return name;
}

// the pid of a temporary folder name, 0 when `name` is not one
pid_t temporaryOwner(const std::string& name) {
  const size_t tag = name.rfind(".tmp.");
  if (name.empty() || name[0] != '.' || tag == std::string::npos) return 0;
  const std::string rest = name.substr(tag + 5);
  const size_t dot = rest.find('.');
  if (dot == std::string::npos || dot == 0 || dot > 9) return 0;
  const std::string pid = rest.substr(0, dot);
  if (!std::all_of(pid.begin(), pid.end(),
                   [](char c) { return c >= '0' && c <= '9'; }))
    return 0;
  return static_cast<pid_t>(std::stol(pid));
}

// removes the temporary folders of dead processes directly under `dir`
void removeStaleFolders(const fs::path& dir) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return;
  std::vector<fs::path> stale;
  for (const auto& entry : fs::directory_iterator(dir, ec)) {
    const pid_t owner = temporaryOwner(entry.path().filename().string());
    if (owner > 0 && ::kill(owner, 0) != 0 && errno == ESRCH)
      stale.push_back(entry.path());
  }
  for (const auto& path : stale) fs::remove_all(path, ec);
}

std::string encodeImage(const cv::Mat& image, const std::string& extension,
                        const std::vector<int>& params, const fs::path& file) {
  std::vector<uint8_t> bytes;
  VLN_CHECK_IO(cv::imencode("." + extension, image, bytes, params),
               "ObservationDump: cannot encode '", file.string(), "'");
  return std::string(bytes.begin(), bytes.end());
}

}  // namespace

// ---------------------------------------------------------------------------
// configuration and conversions

void validate(const DumpConfig& config) {
  VLN_CHECK_ARG(!config.dir.empty(), "DumpConfig: dir is empty");
  VLN_CHECK_ARG(!config.split.empty(), "DumpConfig: split is empty");
  VLN_CHECK_ARG(config.format == "png" || config.format == "jpg",
                "DumpConfig: format must be png or jpg, got '", config.format,
                "'");
  VLN_CHECK_ARG(config.jpeg_quality >= 1 && config.jpeg_quality <= 100,
                "DumpConfig: jpeg_quality must be in [1, 100], got ",
                config.jpeg_quality);
  VLN_CHECK_ARG(config.first_episodes == -1 || config.first_episodes >= 1,
                "DumpConfig: first_episodes must be >= 1 (or -1 for all), got ",
                config.first_episodes);
}

std::string frameFileName(int frame, const std::string& extension) {
  char name[32];
  std::snprintf(name, sizeof(name), "%06d.", frame);
  return name + extension;
}

std::vector<uint16_t> depthMillimetres(const sim::Observation& observation,
                                       const sim::DepthCameraConfig& depth) {
  const float lo = depth.min_depth, hi = depth.max_depth;
  std::vector<uint16_t> mm(observation.depth.size());
  for (size_t i = 0; i < mm.size(); ++i) {
    // undo the normalisation; the far clip and what does not fit read 0
    const float v = observation.depth[i];
    const float metres = depth.normalize_depth ? lo + v * (hi - lo) : v;
    const bool invalid = !std::isfinite(metres) || metres <= 0.0f ||
                         metres >= hi - kMaxDepthTolerance ||
                         metres > kMaxStorableDepth;
    mm[i] = invalid ? 0 : static_cast<uint16_t>(std::lround(metres * 1000.0f));
  }
  return mm;
}

DumpImage readDumpImage(const fs::path& file) {
  const std::string bytes = common::readFile(file);
  const cv::Mat raw(1, static_cast<int>(bytes.size()), CV_8UC1,
                    const_cast<char*>(bytes.data()));
  const cv::Mat image = cv::imdecode(raw, cv::IMREAD_UNCHANGED);
  VLN_CHECK_IO(!image.empty(), "readDumpImage(): cannot decode '",
               file.string(), "'");
  DumpImage out;
  out.width = image.cols;
  out.height = image.rows;
  if (image.type() == CV_8UC3) {
    cv::Mat rgb;
    cv::cvtColor(image, rgb, cv::COLOR_BGR2RGB);
    out.channels = 3;
    out.rgb.assign(rgb.data, rgb.data + rgb.total() * 3);
  } else if (image.type() == CV_16UC1) {
    out.channels = 1;
    const cv::Mat grey = image.isContinuous() ? image : image.clone();
    const auto* data = reinterpret_cast<const uint16_t*>(grey.data);
    out.grey.assign(data, data + grey.total());
  } else {
    throw std::runtime_error(
        strCat("readDumpImage(): '", file.string(),
               "' is neither 8-bit RGB nor 16-bit grey (OpenCV type ",
               image.type(), ")"));
  }
  return out;
}

// ---------------------------------------------------------------------------
// the observer

/// One dumped episode being written.
struct ObservationDump::InProgress {
  const data::Episode* episode = nullptr;
  fs::path temp;                      ///< the folder being written
  std::vector<nlohmann::json> steps;  ///< one record per frame so far
};

ObservationDump::ObservationDump(DumpConfig config,
                                 const std::vector<data::Episode>& episodes)
    : config_(std::move(config)), episodes_(episodes) {
  validate(config_);
  // the chosen input positions
  const std::set<int> ids(config_.episode_ids.begin(),
                          config_.episode_ids.end());
  for (size_t i = 0; i < episodes_.size(); ++i) {
    const bool chosen = ids.empty()
                            ? config_.first_episodes < 0 ||
                                  static_cast<int>(i) < config_.first_episodes
                            : ids.count(episodes_[i].episode_id) > 0;
    if (chosen) chosen_.insert(static_cast<int>(i));
  }
  // leftovers of killed dumps go; finished episodes are never overwritten
  removeStaleFolders(config_.dir / config_.split);
  for (int index : chosen_) {
    const fs::path folder =
        episodeFolder(episodes_[static_cast<size_t>(index)].episode_id);
    VLN_CHECK_ARG(!fs::exists(folder), "ObservationDump: '", folder.string(),
                  "' exists already (dumps never overwrite an episode; remove "
                  "it or dump into another directory)");
  }
}

ObservationDump::~ObservationDump() {
  // episodes cut short by an exception leave no folder behind
  std::error_code ec;
  for (const auto& [env, episode] : running_) fs::remove_all(episode->temp, ec);
}

fs::path ObservationDump::episodeFolder(int episodeId) const {
  return config_.dir / config_.split / std::to_string(episodeId);
}

bool ObservationDump::wantsFrames(int index) const {
  return chosen_.count(index) > 0;
}

void ObservationDump::episodeStarted(int index, rollout::VectorEnv& envs,
                                     int env) {
  if (!wantsFrames(index)) return;
  auto episode = std::make_unique<InProgress>();
  episode->episode = &episodes_[static_cast<size_t>(index)];
  episode->temp =
      config_.dir / config_.split / temporaryName(episode->episode->episode_id);
  fs::create_directories(episode->temp);
  InProgress& e = *episode;
  running_[env] = std::move(episode);
  writeFrame(e, envs, env);
}

void ObservationDump::episodeStepped(int /*index*/, rollout::VectorEnv& envs,
                                     int env, sim::Action action) {
  auto it = running_.find(env);
  if (it == running_.end()) return;
  // the action belongs to the frame it was taken at
  nlohmann::json& last = it->second->steps.back();
  last["action"] = static_cast<int>(action);
  last["action_name"] = std::string(sim::actionName(action));
  writeFrame(*it->second, envs, env);
}

void ObservationDump::writeFrame(InProgress& e, rollout::VectorEnv& envs,
                                 int env) {
  const int frame = static_cast<int>(e.steps.size());
  const sim::Observation& obs = envs.observation(env);
  const sim::EpisodeState& state = envs.state(env);

  // the images
  nlohmann::json step = {{"frame", frame}};
  if (!obs.rgb.empty()) {
    const std::string name = "rgb/" + frameFileName(frame, config_.format);
    cv::Mat rgb(obs.rgb_height, obs.rgb_width, CV_8UC3,
                const_cast<uint8_t*>(obs.rgb.data()));
    cv::Mat bgr;
    cv::cvtColor(rgb, bgr, cv::COLOR_RGB2BGR);
    const std::vector<int> params =
        config_.format == "jpg"
            ? std::vector<int>{cv::IMWRITE_JPEG_QUALITY, config_.jpeg_quality}
            : std::vector<int>{};
    common::writeFileUnsynced(
        e.temp / name, encodeImage(bgr, config_.format, params, e.temp / name));
    step["rgb"] = name;
  } else {
    step["rgb"] = nullptr;
  }
  if (!obs.depth.empty()) {
    const std::string name = "depth/" + frameFileName(frame, "png");
    std::vector<uint16_t> mm = depthMillimetres(obs, config_.depth);
    const cv::Mat depth(obs.depth_height, obs.depth_width, CV_16UC1, mm.data());
    common::writeFileUnsynced(e.temp / name,
                              encodeImage(depth, "png", {}, e.temp / name));
    step["depth"] = name;
  } else {
    step["depth"] = nullptr;
  }

  // the pose and where the goal is
  const sim::AgentState& pose = state.agent;
  const std::array<float, 4> q = headingToQuaternion(pose.heading);
  step["position"] = vec3(pose.position);
  step["heading"] = pose.heading;
  // the cameras' pitch exists in RxR's action space only; R2R dumps stay
  // as they were
  if (envs.simulator(env).config().agent.look_actions)
    step["pitch"] = pose.pitch;
  step["rotation"] = {q[0], q[1], q[2], q[3]};
  step["action"] = nullptr;
  step["action_name"] = nullptr;
  step["collided"] = frame > 0 && state.last_collided;
  step["distance_to_goal"] = nullptr;
  if (!e.episode->goals.empty()) {
    const float d = envs.simulator(env).scene().navmesh().geodesicDistance(
        pose.position, e.episode->goals.front().position);
    if (std::isfinite(d)) step["distance_to_goal"] = d;
  }
  e.steps.push_back(std::move(step));
}

void ObservationDump::episodeFinished(int /*index*/, rollout::VectorEnv& envs,
                                      int env,
                                      const rollout::EpisodeResult& result,
                                      bool scored) {
  auto it = running_.find(env);
  if (it == running_.end()) return;
  InProgress& e = *it->second;
  const data::Episode& episode = *e.episode;

  // the frames
  std::string lines;
  for (const auto& step : e.steps) lines += step.dump() + "\n";
  common::writeFileUnsynced(e.temp / "steps.jsonl", lines);

  // the episode
  const auto& tokens = episode.instruction.instruction_tokens;
  nlohmann::json goals = nlohmann::json::array();
  for (const auto& goal : episode.goals)
    goals.push_back(
        {{"position", vec3(goal.position)}, {"radius", goal.radius}});
  nlohmann::json reference = nlohmann::json::array();
  for (const auto& p : episode.reference_path) reference.push_back(vec3(p));
  const std::vector<int> unpadded(
      tokens.begin(), tokens.begin() + data::unpaddedLength(tokens));
  nlohmann::json words = nullptr;
  if (config_.vocabulary != nullptr) {
    words = nlohmann::json::array();
    for (int token : unpadded)
      words.push_back(token >= 0 && token < config_.vocabulary->size()
                          ? nlohmann::json(config_.vocabulary->word(token))
                          : nlohmann::json(nullptr));
  }
  const sim::Observation& obs = envs.observation(env);
  nlohmann::json json = {
      {"format_version", kFormatVersion},
      {"split", config_.split},
      {"episode_id", episode.episode_id},
      {"trajectory_id", episode.trajectory_id},
      {"scene_id", episode.scene_id},
      {"agent", config_.agent},
      {"instruction",
       {{"text", episode.instruction.instruction_text},
        {"tokens", unpadded},
        {"words", words}}},
      {"start_position", vec3(episode.start_position)},
      {"start_rotation", episode.start_rotation},
      {"goals", goals},
      {"reference_path", reference},
      {"geodesic_distance", episode.geodesic_distance
                                ? nlohmann::json(*episode.geodesic_distance)
                                : nlohmann::json(nullptr)},
      {"num_frames", e.steps.size()},
      {"num_actions", result.record.steps_taken},
      {"called_stop", result.record.called_stop},
      {"metrics", scored ? rollout::metricsToJson(result.metrics)
                         : nlohmann::json(nullptr)},
      {"actions",
       {{"0", "STOP"},
        {"1", "MOVE_FORWARD"},
        {"2", "TURN_LEFT"},
        {"3", "TURN_RIGHT"}}},
      {"cameras",
       {{"rgb",
         {{"width", obs.rgb_width},
          {"height", obs.rgb_height},
          {"hfov_degrees", config_.rgb.hfov},
          {"position_y", config_.rgb.position_y},
          {"format", config_.format}}},
        {"depth",
         {{"width", obs.depth_width},
          {"height", obs.depth_height},
          {"hfov_degrees", config_.depth.camera.hfov},
          {"position_y", config_.depth.camera.position_y},
          {"unit", "millimetre"},
          {"invalid", 0},
          {"min_depth", config_.depth.min_depth},
          {"max_depth", config_.depth.max_depth}}}}},
      {"frames",
       {{"position", "agent feet, world frame, Y up, metres"},
        {"heading", "radians about +Y, 0 looks along -Z"},
        {"rotation", "yaw quaternion [x, y, z, w]"}}}};
  common::writeFileUnsynced(e.temp / "episode.json", json.dump(2) + "\n");

  // complete: durable (one sync for the folder's files), then renamed
  // into place
  common::syncFileSystem(e.temp);
  const fs::path folder = episodeFolder(episode.episode_id);
  std::error_code ec;
  fs::rename(e.temp, folder, ec);
  VLN_CHECK_IO(!ec, "ObservationDump: cannot rename '", e.temp.string(),
               "' to '", folder.string(), "': ", ec.message());
  common::syncDirectory(folder.parent_path());
  folders_.push_back(folder);
  running_.erase(it);
}

}  // namespace vln::viz
