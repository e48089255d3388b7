#include "viz/EpisodeMedia.h"

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "common/Check.h"
#include "sim/Scene.h"
#include "sim/Simulator.h"
#include "sim/TopDownMap.h"
#include "viz/EpisodeMap.h"
#include "viz/Gif.h"
#include "viz/Image.h"
#include "viz/ObservationImages.h"

namespace vln::viz {
namespace {

// caption band under the panels: one line of small text
constexpr int kCaptionHeight = 14;
constexpr double kFontScale = 0.33;
// the map panel is at most this many panel heights wide (a long house is
// scaled to fit and padded above and below)
constexpr int kMaxMapAspect = 3;

// colours of our Mats, which hold RGB
cv::Scalar rgb(const sim::Rgb8& c) { return cv::Scalar(c[0], c[1], c[2]); }

// `source` scaled to `width` x `height` (nearest when enlarging, so small
// observations stay crisp; area averaging when shrinking)
cv::Mat scaled(const cv::Mat& source, int width, int height) {
  cv::Mat out;
  cv::resize(source, out, cv::Size(width, height), 0, 0,
             width >= source.cols ? cv::INTER_NEAREST : cv::INTER_AREA);
  return out;
}

}  // namespace

const char* mediaKindName(EpisodeMediaItem::Kind kind) {
  return kind == EpisodeMediaItem::Kind::kMap ? "map" : "video";
}

// ---------------------------------------------------------------------------
// one episode's GIF

class EpisodeMedia::Video {
 public:
  // draws the map without the agent's path (drawEpisodeMap() of the start
  // alone) and opens the GIF at the size of the three panels
  Video(const MediaConfig& config, const sim::Scene& scene,
        const data::Episode& episode, const sim::AgentState& start,
        const sim::Observation& first, float depthScale)
      : episodeId_(std::to_string(episode.episode_id)),
        depthScale_(depthScale),
        panelHeight_(config.video_height),
        delay_(static_cast<int>(std::lround(100.0 / config.fps))),
        holdDelay_(std::max(delay_, static_cast<int>(std::lround(
                                        100.0 * config.hold_last_seconds)))) {
    VLN_CHECK_ARG(first.rgb_width > 0 && first.rgb_height > 0 &&
                      first.depth_width > 0 && first.depth_height > 0,
                  "EpisodeMedia: episode ", episodeId_,
                  ": no rendered observation (RGB ", first.rgb_width, "x",
                  first.rgb_height, ", depth ", first.depth_width, "x",
                  first.depth_height, ")");
    rgbWidth_ = std::max(
        1, static_cast<int>(std::lround(static_cast<double>(panelHeight_) *
                                        first.rgb_width / first.rgb_height)));
    depthWidth_ = std::max(
        1,
        static_cast<int>(std::lround(static_cast<double>(panelHeight_) *
                                     first.depth_width / first.depth_height)));

    // the map at twice the panel height at most on its long side: finer
    // maps would only be averaged away when scaled into the frame
    MapStyle style = config.map;
    if (style.meters_per_pixel <= 0.0f)
      style.long_side = std::min(style.long_side, 2 * panelHeight_);
    rollout::EpisodeRecord record;
    record.episode_id = episodeId_;
    record.positions = {start.position};
    record.headings = {start.heading};
    record.reference_path = episode.reference_path;
    if (!episode.goals.empty()) record.goal = episode.goals.front().position;
    map_ = std::make_unique<sim::TopDownMap>(drawEpisodeMap(
        scene, record, !episode.goals.empty(), config.success_distance, style));

    // the map panel: the map scaled to the panel height (or to the widest
    // panel allowed), centred vertically on white
    mapScale_ = std::min(
        static_cast<double>(panelHeight_) / map_->height(),
        static_cast<double>(kMaxMapAspect * panelHeight_) / map_->width());
    const int mapWidth =
        std::max(1, static_cast<int>(std::lround(map_->width() * mapScale_)));
    const int mapHeight =
        std::clamp(static_cast<int>(std::lround(map_->height() * mapScale_)), 1,
                   panelHeight_);
    mapTop_ = (panelHeight_ - mapHeight) / 2;
    mapPanel_ =
        cv::Mat(panelHeight_, mapWidth, CV_8UC3, cv::Scalar(255, 255, 255));
    const cv::Mat full(map_->height(), map_->width(), CV_8UC3,
                       const_cast<uint8_t*>(map_->rgb().data()));
    scaled(full, mapWidth, mapHeight)
        .copyTo(mapPanel_(cv::Rect(0, mapTop_, mapWidth, mapHeight)));

    gif_ = std::make_unique<GifEncoder>(rgbWidth_ + depthWidth_ + mapWidth,
                                        panelHeight_ + kCaptionHeight);
  }

  // draws the frame of the agent at `pose` after `step` actions and hands
  // the previous one to the GIF (the last frame's delay is longer)
  void addFrame(const sim::Observation& observation,
                const sim::AgentState& pose, int step,
                const sim::Action* action, float distance) {
    VLN_CHECK_ARG(
        observation.rgb.size() == static_cast<size_t>(observation.rgb_width) *
                                      observation.rgb_height * 3 &&
            observation.depth.size() ==
                static_cast<size_t>(observation.depth_width) *
                    observation.depth_height &&
            !observation.rgb.empty() && !observation.depth.empty(),
        "EpisodeMedia: episode ", episodeId_, ", step ", step,
        ": no rendered observation (was the frame requested?)");
    const int width = gif_->width();
    cv::Mat frame(gif_->height(), width, CV_8UC3, cv::Scalar(255, 255, 255));

    // RGB and depth (grey levels of depth / scale, clipped to [0, 1])
    const cv::Mat color(observation.rgb_height, observation.rgb_width, CV_8UC3,
                        const_cast<uint8_t*>(observation.rgb.data()));
    scaled(color, rgbWidth_, panelHeight_)
        .copyTo(frame(cv::Rect(0, 0, rgbWidth_, panelHeight_)));
    std::vector<uint8_t> levels = depthGreyLevels(observation, depthScale_);
    const cv::Mat grey(observation.depth_height, observation.depth_width,
                       CV_8UC1, levels.data());
    cv::Mat depthRgb;
    cv::cvtColor(scaled(grey, depthWidth_, panelHeight_), depthRgb,
                 cv::COLOR_GRAY2RGB);
    depthRgb.copyTo(frame(cv::Rect(rgbWidth_, 0, depthWidth_, panelHeight_)));

    // the path so far stays on the map panel; the agent only on this frame
    const cv::Point at = toPanel(pose.position);
    if (hasPrevious_ && at != previous_)
      cv::line(mapPanel_, previous_, at, rgb(kAgentColor), 2, cv::LINE_AA);
    previous_ = at;
    hasPrevious_ = true;
    cv::Mat mapView = frame(
        cv::Rect(rgbWidth_ + depthWidth_, 0, mapPanel_.cols, panelHeight_));
    mapPanel_.copyTo(mapView);
    const Vec3f forward = headingToForward(pose.heading);
    const double norm = std::hypot(forward.x(), forward.z());
    const cv::Point tip(
        at.x + static_cast<int>(std::lround(7.0 * forward.x() / norm)),
        at.y + static_cast<int>(std::lround(7.0 * forward.z() / norm)));
    cv::circle(mapView, at, 3, rgb(kAgentColor), cv::FILLED, cv::LINE_AA);
    cv::arrowedLine(mapView, at, tip, cv::Scalar(0, 0, 0), 1, cv::LINE_AA, 0,
                    0.4);

    // caption: step, action, distance to the goal
    char caption[128];
    int n = std::snprintf(caption, sizeof(caption), "step %d", step);
    if (action != nullptr)
      n += std::snprintf(caption + n, sizeof(caption) - n, "  %s",
                         std::string(sim::actionName(*action)).c_str());
    if (distance >= 0.0f && std::isfinite(distance))
      std::snprintf(caption + n, sizeof(caption) - n, "  %.1f m to goal",
                    static_cast<double>(distance));
    cv::putText(frame, caption, cv::Point(3, panelHeight_ + 10),
                cv::FONT_HERSHEY_SIMPLEX, kFontScale, cv::Scalar(40, 40, 40), 1,
                cv::LINE_AA);

    if (!pending_.empty()) gif_->addFrame(pending_, delay_);
    pending_.assign(frame.data, frame.data + frame.total() * 3);
  }

  EpisodeMediaItem finish(int index) {
    gif_->addFrame(pending_, holdDelay_);
    EpisodeMediaItem item;
    item.kind = EpisodeMediaItem::Kind::kVideo;
    item.index = index;
    item.episode_id = episodeId_;
    item.width = gif_->width();
    item.height = gif_->height();
    item.frames = gif_->frames();
    item.encoded = gif_->finish();
    return item;
  }

 private:
  // pixel of the map panel showing a world point
  cv::Point toPanel(const Vec3f& p) const {
    const Eigen::Vector2i pixel = map_->toPixel(p);
    return {
        static_cast<int>(std::lround((pixel.x() + 0.5) * mapScale_)),
        mapTop_ + static_cast<int>(std::lround((pixel.y() + 0.5) * mapScale_))};
  }

  std::string episodeId_;
  float depthScale_;
  int panelHeight_;
  int delay_;
  int holdDelay_;
  int rgbWidth_ = 0;
  int depthWidth_ = 0;
  std::unique_ptr<sim::TopDownMap> map_;
  double mapScale_ = 1.0;
  int mapTop_ = 0;
  cv::Mat mapPanel_;  ///< RGB, with the agent's path so far
  bool hasPrevious_ = false;
  cv::Point previous_;
  std::vector<uint8_t> pending_;  ///< the last frame, not yet in the GIF
  std::unique_ptr<GifEncoder> gif_;
};

// ---------------------------------------------------------------------------
// the observer

EpisodeMedia::EpisodeMedia(MediaConfig config) : config_(std::move(config)) {
  VLN_CHECK_ARG(config_.maps >= 0 && config_.videos >= 0,
                "EpisodeMedia: episode counts must be >= 0, got maps ",
                config_.maps, ", videos ", config_.videos);
  VLN_CHECK_ARG(config_.video_height >= 16,
                "EpisodeMedia: video height must be >= 16 px, got ",
                config_.video_height);
  VLN_CHECK_ARG(config_.fps > 0.0 && config_.fps <= 100.0,
                "EpisodeMedia: fps must be in (0, 100], got ", config_.fps);
}

EpisodeMedia::~EpisodeMedia() = default;

bool EpisodeMedia::wantsFrames(int index) const {
  return index < config_.videos;
}

void EpisodeMedia::episodeStarted(int index, rollout::VectorEnv& envs,
                                  int env) {
  if (!wantsFrames(index)) return;
  const sim::Simulator& simulator = envs.simulator(env);
  const data::Episode& episode = envs.episode(env);
  const sim::Observation& observation = envs.observation(env);
  const float depthScale = depthDisplayScale(simulator);
  const sim::AgentState& pose = simulator.episode().agent;
  auto video = std::make_unique<Video>(config_, simulator.scene(), episode,
                                       pose, observation, depthScale);
  video->addFrame(observation, pose, /*step=*/0, /*action=*/nullptr,
                  distanceToGoal(simulator, episode, pose.position));
  videos_[env] = std::move(video);
}

void EpisodeMedia::episodeStepped(int /*index*/, rollout::VectorEnv& envs,
                                  int env, sim::Action action) {
  const auto it = videos_.find(env);
  if (it == videos_.end()) return;
  const sim::Simulator& simulator = envs.simulator(env);
  const sim::EpisodeState& state = simulator.episode();
  it->second->addFrame(
      envs.observation(env), state.agent, state.steps, &action,
      distanceToGoal(simulator, envs.episode(env), state.agent.position));
}

void EpisodeMedia::episodeFinished(int index, rollout::VectorEnv& envs, int env,
                                   const rollout::EpisodeResult& result,
                                   bool scored) {
  if (const auto it = videos_.find(env); it != videos_.end()) {
    items_.push_back(it->second->finish(index));
    videos_.erase(it);
  }
  if (index >= config_.maps) return;
  const Image picture =
      mapPicture(drawEpisodeMap(envs.simulator(env).scene(), result.record,
                                scored, config_.success_distance, config_.map),
                 mapLegendOf(result.record, scored, config_.success_distance));
  EpisodeMediaItem item;
  item.kind = EpisodeMediaItem::Kind::kMap;
  item.index = index;
  item.episode_id = result.record.episode_id;
  item.width = picture.width;
  item.height = picture.height;
  item.encoded = encodePng(picture);
  items_.push_back(std::move(item));
}

std::vector<EpisodeMediaItem> EpisodeMedia::take() {
  std::stable_sort(items_.begin(), items_.end(),
                   [](const EpisodeMediaItem& a, const EpisodeMediaItem& b) {
                     return std::pair(a.kind, a.index) <
                            std::pair(b.kind, b.index);
                   });
  std::vector<EpisodeMediaItem> out = std::move(items_);
  items_.clear();
  return out;
}

}  // namespace vln::viz
