#include "viz/EpisodePictures.h"

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "common/Check.h"
#include "viz/ObservationImages.h"

namespace vln::viz {
namespace fs = std::filesystem;

namespace {

// caption band below the panels: two lines of text
constexpr int kCaptionHeight = 48;
constexpr double kFontScale = 0.45;

cv::Scalar bgr(const sim::Rgb8& c) { return cv::Scalar(c[2], c[1], c[0]); }

// sizes in multiples of 8 pixels (whole JPEG blocks; OpenCV 4.6's own MJPEG
// encoder writes corrupt frames 102 px wide but not 104 px wide, and mp4v
// needs even sizes)
int ceil8(double value) {
  const int v = std::max(8, static_cast<int>(std::lround(value)));
  return (v + 7) / 8 * 8;
}

// an RGB image as a BGR panel of `width` x `height`
cv::Mat rgbPanel(const uint8_t* rgb, int w, int h, int width, int height) {
  cv::Mat source(h, w, CV_8UC3, const_cast<uint8_t*>(rgb));
  cv::Mat converted;
  cv::cvtColor(source, converted, cv::COLOR_RGB2BGR);
  cv::Mat out;
  // nearest keeps small observations crisp when scaled up
  cv::resize(converted, out, cv::Size(width, height), 0, 0,
             width >= w ? cv::INTER_NEAREST : cv::INTER_AREA);
  return out;
}

// a depth image as grey levels value / scale, clipped to [0, 1]
cv::Mat depthPanel(const sim::Observation& observation, float scale, int width,
                   int height) {
  const int w = observation.depth_width;
  std::vector<uint8_t> levels = depthGreyLevels(observation, scale);
  cv::Mat grey(observation.depth_height, w, CV_8UC1, levels.data());
  cv::Mat scaled, out;
  cv::resize(grey, scaled, cv::Size(width, height), 0, 0,
             width >= w ? cv::INTER_NEAREST : cv::INTER_AREA);
  cv::cvtColor(scaled, out, cv::COLOR_GRAY2BGR);
  return out;
}

// the longest prefix of `text` that fits in `width` pixels (with "...")
std::string fitText(const std::string& text, int width) {
  int baseline = 0;
  auto fits = [&](const std::string& s) {
    return cv::getTextSize(s, cv::FONT_HERSHEY_SIMPLEX, kFontScale, 1,
                           &baseline)
               .width <= width;
  };
  if (fits(text)) return text;
  size_t lo = 0, hi = text.size();
  while (lo < hi) {
    const size_t mid = (lo + hi + 1) / 2;
    if (fits(text.substr(0, mid) + "...")) {
      lo = mid;
    } else {
      hi = mid - 1;
    }
  }
  return text.substr(0, lo) + "...";
}

}  // namespace

// ---------------------------------------------------------------------------
// videos

std::string videoFileName(const std::string& prefix,
                          const std::string& episodeId,
                          const std::string& format) {
  return prefix + "episode_" + episodeId + "." + format;
}

struct EpisodeVideo::Impl {
  fs::path file;
  fs::path partial;
  cv::VideoWriter writer;
  sim::TopDownMap map;
  std::string instruction;
  int panelHeight = 0;
  int rgbWidth = 0, depthWidth = 0, mapWidth = 0;
  int obsRgbWidth = 0, obsRgbHeight = 0, obsDepthWidth = 0, obsDepthHeight = 0;
  float depthScale = 1.0f;
  bool hasPrevious = false;
  Vec3f previous = Vec3f::Zero();
  bool closed = false;

  Impl(const sim::Scene& scene, float metersPerPixel, float floorY)
      : map(scene, metersPerPixel, floorY) {}
};

EpisodeVideo::EpisodeVideo(const fs::path& file, const PicturesConfig& config,
                           const sim::Scene& scene,
                           const data::Episode& episode,
                           const std::vector<Vec3f>& reference, int rgbWidth,
                           int rgbHeight, int depthWidth, int depthHeight,
                           float depthScale) {
  VLN_CHECK_ARG(config.video_format == "avi" || config.video_format == "mp4",
                "EpisodeVideo: video format must be avi or mp4, got '",
                config.video_format, "'");
  VLN_CHECK_ARG(
      rgbWidth > 0 && rgbHeight > 0 && depthWidth > 0 && depthHeight > 0,
      "EpisodeVideo: episode ", episode.episode_id,
      ": observation sizes must be positive, got RGB ", rgbWidth, "x",
      rgbHeight, ", depth ", depthWidth, "x", depthHeight);
  VLN_CHECK_ARG(config.video_height >= 16,
                "EpisodeVideo: video height must be "
                ">= 16 px, got ",
                config.video_height);
  VLN_CHECK_ARG(depthScale > 0.0f, "EpisodeVideo: depth scale must be > 0");
  // the map panel is at most twice the panel height on its long side:
  // finer maps would only be averaged away when scaled into the frame
  const int panelHeight = ceil8(config.video_height);
  MapStyle style = config.map;
  if (style.meters_per_pixel <= 0.0f)
    style.long_side = std::min(style.long_side, 2 * panelHeight);
  impl_ = std::make_unique<Impl>(
      scene, style.metersPerPixel(scene, episode.start_position.y()),
      episode.start_position.y());
  Impl& m = *impl_;
  m.file = file;
  m.instruction = episode.instruction.instruction_text;
  m.depthScale = depthScale;
  m.obsRgbWidth = rgbWidth;
  m.obsRgbHeight = rgbHeight;
  m.obsDepthWidth = depthWidth;
  m.obsDepthHeight = depthHeight;

  // what the agent should do, drawn once; its own path grows frame by frame
  if (reference.size() >= 2) m.map.drawPath(reference, kReferenceColor, 3);
  if (!episode.goals.empty()) {
    m.map.drawCircle(episode.goals.front().position, config.success_distance,
                     kGoalColor, 2);
    m.map.drawPoint(episode.goals.front().position, kGoalColor, 5);
  }
  m.map.drawPoint(episode.start_position, kStartColor, 5);

  // panel sizes: every panel as high as the video, widths keep aspect
  m.panelHeight = panelHeight;
  m.rgbWidth = ceil8(static_cast<double>(rgbWidth) * m.panelHeight / rgbHeight);
  m.depthWidth =
      ceil8(static_cast<double>(depthWidth) * m.panelHeight / depthHeight);
  m.mapWidth = ceil8(static_cast<double>(m.map.width()) * m.panelHeight /
                     std::max(1, m.map.height()));

  // OpenCV picks the container by extension, so the partial file keeps it
  std::error_code ec;
  fs::create_directories(
      file.parent_path().empty() ? fs::path(".") : file.parent_path(), ec);
  m.partial = file;
  m.partial.replace_filename(file.stem().string() + ".partial" +
                             file.extension().string());
  // FFmpeg (libavcodec, a dependency of Debian's libopencv-videoio) encodes
  // both formats; OpenCV's own MJPEG encoder is only the fallback because
  // OpenCV 4.6's writes some frames as corrupt JPEG ("error dc" when
  // decoding) depending on their content
  const bool avi = config.video_format == "avi";
  const int fourcc = avi ? cv::VideoWriter::fourcc('M', 'J', 'P', 'G')
                         : cv::VideoWriter::fourcc('m', 'p', '4', 'v');
  const cv::Size size(width(), height());
  m.writer.open(m.partial.string(), cv::CAP_FFMPEG, fourcc, config.fps, size);
  if (!m.writer.isOpened() && avi)
    m.writer.open(m.partial.string(), cv::CAP_OPENCV_MJPEG, fourcc, config.fps,
                  size);
  VLN_CHECK_IO(m.writer.isOpened(), "EpisodeVideo: cannot write '",
               m.partial.string(), "' as ", avi ? "MJPG .avi" : "mp4v .mp4",
               " (OpenCV VideoWriter failed to open)");
}

EpisodeVideo::~EpisodeVideo() {
  // an unfinished video (an exception during evaluation) is not left behind
  if (impl_ && !impl_->closed) {
    impl_->writer.release();
    std::error_code ec;
    fs::remove(impl_->partial, ec);
  }
}

int EpisodeVideo::width() const {
  return impl_->rgbWidth + impl_->depthWidth + impl_->mapWidth;
}

int EpisodeVideo::height() const { return impl_->panelHeight + kCaptionHeight; }

void EpisodeVideo::addFrame(const sim::Observation& observation,
                            const sim::AgentState& pose, int step,
                            const sim::Action* action, float distanceToGoal) {
  Impl& m = *impl_;
  VLN_CHECK_ARG(!m.closed, "EpisodeVideo::addFrame(): '", m.file.string(),
                "' is already closed");
  VLN_CHECK_ARG(
      observation.rgb_width == m.obsRgbWidth &&
          observation.rgb_height == m.obsRgbHeight &&
          observation.depth_width == m.obsDepthWidth &&
          observation.depth_height == m.obsDepthHeight &&
          observation.rgb.size() ==
              static_cast<size_t>(m.obsRgbWidth) * m.obsRgbHeight * 3 &&
          observation.depth.size() ==
              static_cast<size_t>(m.obsDepthWidth) * m.obsDepthHeight,
      "EpisodeVideo::addFrame(): '", m.file.string(), "': observation is RGB ",
      observation.rgb_width, "x", observation.rgb_height, ", depth ",
      observation.depth_width, "x", observation.depth_height,
      " (was the frame rendered?), expected ", m.obsRgbWidth, "x",
      m.obsRgbHeight, " and ", m.obsDepthWidth, "x", m.obsDepthHeight);

  // the path so far stays on the map; the agent marker only on this frame
  if (m.hasPrevious && !(m.previous == pose.position))
    m.map.drawPath({m.previous, pose.position}, kAgentColor, 2);
  m.previous = pose.position;
  m.hasPrevious = true;
  cv::Mat mapRgb(m.map.height(), m.map.width(), CV_8UC3,
                 const_cast<uint8_t*>(m.map.rgb().data()));
  cv::Mat mapBgr;
  cv::cvtColor(mapRgb, mapBgr, cv::COLOR_RGB2BGR);
  const Eigen::Vector2i at = m.map.toPixel(pose.position);
  const Vec3f ahead = pose.position + headingToForward(pose.heading) * 0.6f;
  const Eigen::Vector2i tip = m.map.toPixel(ahead);
  cv::circle(mapBgr, cv::Point(at.x(), at.y()), 4, bgr(kAgentColor),
             cv::FILLED);
  cv::arrowedLine(mapBgr, cv::Point(at.x(), at.y()),
                  cv::Point(tip.x(), tip.y()), cv::Scalar(0, 0, 0), 2,
                  cv::LINE_AA, 0, 0.4);
  cv::Mat mapPanel;
  cv::resize(mapBgr, mapPanel, cv::Size(m.mapWidth, m.panelHeight), 0, 0,
             cv::INTER_AREA);

  // RGB | depth | map over the caption band
  cv::Mat frame(height(), width(), CV_8UC3, cv::Scalar(255, 255, 255));
  rgbPanel(observation.rgb.data(), m.obsRgbWidth, m.obsRgbHeight, m.rgbWidth,
           m.panelHeight)
      .copyTo(frame(cv::Rect(0, 0, m.rgbWidth, m.panelHeight)));
  depthPanel(observation, m.depthScale, m.depthWidth, m.panelHeight)
      .copyTo(frame(cv::Rect(m.rgbWidth, 0, m.depthWidth, m.panelHeight)));
  mapPanel.copyTo(
      frame(cv::Rect(m.rgbWidth + m.depthWidth, 0, m.mapWidth, m.panelHeight)));
  std::string status = "step " + std::to_string(step);
  if (action != nullptr) status += "  " + std::string(sim::actionName(*action));
  if (distanceToGoal >= 0.0f) {
    char distance[64];
    std::snprintf(distance, sizeof(distance), "  distance to goal %.2f m",
                  static_cast<double>(distanceToGoal));
    status += distance;
  }
  const int textWidth = width() - 8;
  cv::putText(frame, fitText(m.instruction, textWidth),
              cv::Point(4, m.panelHeight + 17), cv::FONT_HERSHEY_SIMPLEX,
              kFontScale, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  cv::putText(frame, fitText(status, textWidth),
              cv::Point(4, m.panelHeight + 37), cv::FONT_HERSHEY_SIMPLEX,
              kFontScale, cv::Scalar(60, 60, 60), 1, cv::LINE_AA);
  m.writer.write(frame);
  ++frames_;
}

void EpisodeVideo::close() {
  Impl& m = *impl_;
  if (m.closed) return;
  m.writer.release();
  std::error_code ec;
  fs::rename(m.partial, m.file, ec);
  VLN_CHECK_IO(!ec, "EpisodeVideo::close(): cannot rename '",
               m.partial.string(), "' to '", m.file.string(),
               "': ", ec.message());
  m.closed = true;
}

VideoSummary summarizeVideo(const fs::path& file) {
  VLN_CHECK_IO(fs::is_regular_file(file), "summarizeVideo(): '", file.string(),
               "' does not exist");
  cv::VideoCapture capture(file.string());
  VLN_CHECK_IO(capture.isOpened(), "summarizeVideo(): OpenCV cannot open '",
               file.string(), "'");
  VideoSummary summary;
  cv::Mat frame, grey;
  while (capture.read(frame)) {
    cv::cvtColor(frame, grey, cv::COLOR_BGR2GRAY);
    cv::Scalar mean, stddev;
    cv::meanStdDev(grey, mean, stddev);
    if (summary.frames == 0) {
      summary.width = frame.cols;
      summary.height = frame.rows;
      summary.first_frame_stddev = stddev[0];
    }
    summary.frame_means.push_back(mean[0]);
    ++summary.frames;
  }
  VLN_CHECK_IO(summary.frames > 0, "summarizeVideo(): '", file.string(),
               "' holds no decodable frame");
  return summary;
}

// ---------------------------------------------------------------------------
// the observer

EpisodePictures::EpisodePictures(PicturesConfig config)
    : config_(std::move(config)) {
  VLN_CHECK_ARG(config_.map_episodes >= 0 && config_.video_episodes >= 0,
                "EpisodePictures: episode counts must be >= 0, got maps ",
                config_.map_episodes, ", videos ", config_.video_episodes);
  VLN_CHECK_ARG(config_.video_format == "avi" || config_.video_format == "mp4",
                "EpisodePictures: video format must be avi or mp4, got '",
                config_.video_format, "'");
}

EpisodePictures::~EpisodePictures() = default;

bool EpisodePictures::wantsFrames(int index) const {
  return index < config_.video_episodes;
}

void EpisodePictures::episodeStarted(int index, rollout::VectorEnv& envs,
                                     int env) {
  if (!wantsFrames(index)) return;
  const sim::Simulator& simulator = envs.simulator(env);
  const data::Episode& episode = envs.episode(env);
  const sim::Observation& obs = envs.observation(env);
  const float scale = depthDisplayScale(simulator);
  const fs::path file =
      config_.dir / videoFileName(config_.prefix,
                                  std::to_string(episode.episode_id),
                                  config_.video_format);
  auto video = std::make_unique<EpisodeVideo>(
      file, config_, simulator.scene(), episode, episode.reference_path,
      obs.rgb_width, obs.rgb_height, obs.depth_width, obs.depth_height, scale);
  const sim::AgentState& pose = simulator.episode().agent;
  video->addFrame(obs, pose, /*step=*/0, /*action=*/nullptr,
                  distanceToGoal(simulator, episode, pose.position));
  videos_[env] = std::move(video);
}

void EpisodePictures::episodeStepped(int /*index*/, rollout::VectorEnv& envs,
                                     int env, sim::Action action) {
  auto it = videos_.find(env);
  if (it == videos_.end()) return;
  const sim::Simulator& simulator = envs.simulator(env);
  const sim::EpisodeState& state = simulator.episode();
  it->second->addFrame(
      envs.observation(env), state.agent, state.steps, &action,
      distanceToGoal(simulator, envs.episode(env), state.agent.position));
}

void EpisodePictures::episodeFinished(int index, rollout::VectorEnv& envs,
                                      int env,
                                      const rollout::EpisodeResult& result,
                                      bool scored) {
  auto it = videos_.find(env);
  if (it != videos_.end()) {
    it->second->close();
    files_.push_back(config_.dir / videoFileName(config_.prefix,
                                                 result.record.episode_id,
                                                 config_.video_format));
    videos_.erase(it);
  }
  if (index >= config_.map_episodes) return;
  const sim::TopDownMap map =
      drawEpisodeMap(envs.simulator(env).scene(), result.record, scored,
                     config_.success_distance, config_.map);
  const fs::path file =
      config_.dir / mapFileName(config_.prefix, result.record.episode_id);
  savePng(mapPicture(map, mapLegendOf(result.record, scored,
                                      config_.success_distance)),
          file);
  files_.push_back(file);
}

}  // namespace vln::viz
