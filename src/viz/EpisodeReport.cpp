#include "viz/EpisodeReport.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include <nlohmann/json.hpp>

#include "common/Check.h"
#include "common/FileIo.h"
#include "data/Episode.h"
#include "viz/Image.h"
#include "viz/ObservationImages.h"
#include "viz/ReportPage.h"

namespace vln::viz {
namespace fs = std::filesystem;
using nlohmann::json;

// Columns of the episode table, in order: VLN-CE's measure names.
static constexpr const char* kTableMetrics[] = {
    "success",        "spl",        "ndtw", "distance_to_goal", "path_length",
    "oracle_success", "steps_taken"};

struct EpisodeReport::Episode {
  int index = 0;
  std::string id;
  std::string instruction;
  std::vector<std::string> words;  ///< the tokens the policy reads
  bool detail = false;
  int frames = 0;
  std::vector<std::string> actions;           ///< one per step
  std::vector<double> distance;               ///< to the goal, per frame
  std::vector<std::vector<float>> attention;  ///< per step, over words
  rollout::EpisodeMetrics metrics;
  bool scored = false;
  bool called_stop = false;
  // the map, once finished
  std::string map;
  int map_width = 0, map_height = 0, map_picture_height = 0;
  std::vector<std::array<int, 2>> path;  ///< map pixels per frame
  std::vector<float> headings;
};

namespace {

std::string frameDir(const std::string& id) { return "frames/episode_" + id; }

std::string frameName(const std::string& id, int step) {
  char name[32];
  std::snprintf(name, sizeof(name), "/step_%03d.jpg", step);
  return frameDir(id) + name;
}

// RGB | depth side by side, depth as grey levels value / scale
Image framePicture(const sim::Observation& obs, float depthScale) {
  const int height = std::max(obs.rgb_height, obs.depth_height);
  Image rgb{obs.rgb_width, obs.rgb_height, obs.rgb};
  Image depth{obs.depth_width, obs.depth_height, {}};
  const std::vector<uint8_t> levels = depthGreyLevels(obs, depthScale);
  depth.rgb.resize(levels.size() * 3);
  for (size_t i = 0; i < levels.size(); ++i)
    depth.rgb[3 * i] = depth.rgb[3 * i + 1] = depth.rgb[3 * i + 2] = levels[i];
  auto toHeight = [&](const Image& image) {
    if (image.height == height) return image;
    const int width = std::max(
        1, static_cast<int>(std::lround(static_cast<double>(image.width) *
                                        height / image.height)));
    return resizeImage(image, width, height);
  };
  const Image left = toHeight(rgb);
  const Image right = toHeight(depth);
  Image out{left.width + right.width, height, {}};
  out.rgb.resize(static_cast<size_t>(out.width) * height * 3);
  for (int y = 0; y < height; ++y) {
    std::copy_n(left.rgb.begin() + static_cast<long>(y) * left.width * 3,
                left.width * 3,
                out.rgb.begin() + static_cast<long>(y) * out.width * 3);
    std::copy_n(
        right.rgb.begin() + static_cast<long>(y) * right.width * 3,
        right.width * 3,
        out.rgb.begin() + (static_cast<long>(y) * out.width + left.width) * 3);
  }
  return out;
}

// the words of the tokens the policy reads (unpadded, capped), or the
// instruction's words when it has no tokens
std::vector<std::string> instructionWords(const data::Episode& episode,
                                          const data::Vocabulary* vocabulary,
                                          int maxLength) {
  const auto& tokens = episode.instruction.instruction_tokens;
  const int length = std::min(maxLength, data::unpaddedLength(tokens));
  std::vector<std::string> words;
  if (length <= 0) {
    std::istringstream in(episode.instruction.instruction_text);
    for (std::string w; in >> w;) words.push_back(w);
    return words;
  }
  for (int i = 0; i < length; ++i) {
    const int token = tokens[static_cast<size_t>(i)];
    if (vocabulary != nullptr && token >= 0 && token < vocabulary->size())
      words.push_back(vocabulary->word(token));
    else {
      // appended, not "#" + to_string(): GCC 12 warns (-Wstringop-overflow)
      std::string number = "#";
      number += std::to_string(token);
      words.push_back(std::move(number));
    }
  }
  return words;
}

// a JSON number that stays valid JSON (NaN and infinities become null)
json finite(double value) {
  return std::isfinite(value) ? json(value) : json(nullptr);
}

}  // namespace

EpisodeReport::EpisodeReport(ReportConfig config, const rollout::Agent* agent)
    : config_(std::move(config)), agent_(agent) {
  VLN_CHECK_ARG(!config_.dir.empty(), "EpisodeReport: no output folder given");
  VLN_CHECK_ARG(config_.detail_episodes >= 0,
                "EpisodeReport: detail episodes must be >= 0, got ",
                config_.detail_episodes);
  VLN_CHECK_ARG(config_.frame_quality >= 1 && config_.frame_quality <= 100,
                "EpisodeReport: frame quality must be in [1, 100], got ",
                config_.frame_quality);
  VLN_CHECK_ARG(config_.max_instruction_length >= 1,
                "EpisodeReport: max instruction length must be >= 1");
}

EpisodeReport::~EpisodeReport() = default;

bool EpisodeReport::wantsFrames(int index) const {
  return index < config_.detail_episodes;
}

void EpisodeReport::episodeStarted(int index, rollout::VectorEnv& envs,
                                   int env) {
  auto episode = std::make_unique<Episode>();
  const data::Episode& source = envs.episode(env);
  episode->index = index;
  episode->id = std::to_string(source.episode_id);
  episode->instruction = source.instruction.instruction_text;
  episode->detail = wantsFrames(index);
  if (episode->detail) {
    episode->words = instructionWords(source, config_.vocabulary,
                                      config_.max_instruction_length);
    const sim::Simulator& simulator = envs.simulator(env);
    common::writeFileAtomic(
        config_.dir / frameName(episode->id, 0),
        encodeJpeg(
            framePicture(envs.observation(env), depthDisplayScale(simulator)),
            config_.frame_quality));
    episode->frames = 1;
    episode->distance.push_back(
        distanceToGoal(simulator, source, simulator.episode().agent.position));
  }
  running_[env] = std::move(episode);
}

void EpisodeReport::episodeStepped(int /*index*/, rollout::VectorEnv& envs,
                                   int env, sim::Action action) {
  auto it = running_.find(env);
  if (it == running_.end() || !it->second->detail) return;
  Episode& e = *it->second;
  e.actions.emplace_back(sim::actionName(action));
  if (agent_ != nullptr)
    e.attention.push_back(agent_->instructionAttention(env));
  const sim::Simulator& simulator = envs.simulator(env);
  common::writeFileAtomic(config_.dir / frameName(e.id, e.frames),
                          encodeJpeg(framePicture(envs.observation(env),
                                                  depthDisplayScale(simulator)),
                                     config_.frame_quality));
  ++e.frames;
  e.distance.push_back(distanceToGoal(simulator, envs.episode(env),
                                      simulator.episode().agent.position));
}

void EpisodeReport::episodeFinished(int index, rollout::VectorEnv& envs,
                                    int env,
                                    const rollout::EpisodeResult& result,
                                    bool scored) {
  auto it = running_.find(env);
  VLN_ASSERT(it != running_.end());  // every episode starts before it ends
  std::unique_ptr<Episode> e = std::move(it->second);
  running_.erase(it);
  e->metrics = result.metrics;
  e->scored = scored;
  e->called_stop = result.record.called_stop;
  if (e->detail) {
    const sim::TopDownMap map =
        drawEpisodeMap(envs.simulator(env).scene(), result.record, scored,
                       config_.success_distance, config_.map);
    const Image picture = mapPicture(
        map, mapLegendOf(result.record, scored, config_.success_distance));
    e->map = "maps/episode_" + e->id + ".png";
    savePng(picture, config_.dir / e->map);
    e->map_width = map.width();
    e->map_height = map.height();
    e->map_picture_height = picture.height;
    for (const Vec3f& p : result.record.positions) {
      const Eigen::Vector2i px = map.toPixel(p);
      e->path.push_back({px.x(), px.y()});
    }
    e->headings = result.record.headings;
  }
  finished_[index] = std::move(e);
}

fs::path EpisodeReport::write() const {
  json episodes = json::array();
  json details = json::object();
  std::map<std::string, double> sums;
  int scored = 0;
  for (const auto& [index, e] : finished_) {
    json metrics = json::object();
    for (const auto& [name, field] : rollout::kMetricFields)
      metrics[name] = e->scored ? finite(e->metrics.*field) : json(nullptr);
    if (e->scored) {
      ++scored;
      for (const auto& [name, field] : rollout::kMetricFields)
        sums[name] += e->metrics.*field;
    }
    episodes.push_back({{"index", index},
                        {"id", e->id},
                        {"instruction", e->instruction},
                        {"scored", e->scored},
                        {"called_stop", e->called_stop},
                        {"detail", e->detail},
                        {"metrics", metrics}});
    if (!e->detail) continue;
    json attention = json::array();
    bool anyAttention = false;
    for (const auto& row : e->attention) {
      // rows that do not match the words (no attention) become null
      if (row.size() == e->words.size() && !row.empty()) {
        attention.push_back(row);
        anyAttention = true;
      } else {
        attention.push_back(nullptr);
      }
    }
    json distance = json::array();
    for (float d : e->distance)
      distance.push_back(d >= 0.0 ? finite(d) : json(nullptr));
    details[e->id] = {{"words", e->words},
                      {"frame_dir", frameDir(e->id)},
                      {"frames", e->frames},
                      {"actions", e->actions},
                      {"distance", distance},
                      {"attention", anyAttention ? attention : json(nullptr)},
                      {"map", e->map},
                      {"map_size", {e->map_width, e->map_height}},
                      {"map_picture_height", e->map_picture_height},
                      {"path", e->path},
                      {"headings", e->headings}};
  }
  json summary = json::object();
  for (const auto& [name, field] : rollout::kMetricFields)
    summary[name] = scored > 0 ? finite(sums[name] / scored) : json(nullptr);
  json columns = json::array();
  for (const char* name : kTableMetrics) columns.push_back(name);
  const json data = {
      {"title", config_.title},    {"episodes_total", episodes.size()},
      {"episodes_scored", scored}, {"summary", summary},
      {"columns", columns},        {"episodes", episodes},
      {"details", details}};
  const fs::path page = config_.dir / "index.html";
  common::writeFileAtomic(page, reportPageHtml(data));
  common::writeFileAtomic(config_.dir / "report.json",
                          json{{"title", config_.title},
                               {"episodes", episodes.size()},
                               {"episodes_scored", scored},
                               {"summary", summary}}
                              .dump(2));
  return page;
}

fs::path writeReportIndex(const fs::path& root) {
  json reports = json::array();
  std::vector<fs::path> folders;
  if (fs::is_directory(root))
    for (const auto& entry : fs::directory_iterator(root))
      if (entry.is_directory() &&
          fs::is_regular_file(entry.path() / "report.json"))
        folders.push_back(entry.path());
  std::sort(folders.begin(), folders.end());
  for (const fs::path& folder : folders) {
    const fs::path file = folder / "report.json";
    json report;
    try {
      report = json::parse(common::readFile(file));
    } catch (const json::exception& e) {
      throw std::runtime_error("writeReportIndex(): '" + file.string() +
                               "' is not valid JSON: " + e.what());
    }
    report["href"] = folder.filename().string() + "/index.html";
    reports.push_back(report);
  }
  const fs::path page = root / "index.html";
  common::writeFileAtomic(page, reportIndexHtml(reports));
  return page;
}

}  // namespace vln::viz
