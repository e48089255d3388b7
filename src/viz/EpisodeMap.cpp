#include "viz/EpisodeMap.h"

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "common/Check.h"

namespace vln::viz {

namespace {

constexpr int kFont = cv::FONT_HERSHEY_SIMPLEX;
constexpr double kFontScale = 0.45;
constexpr int kPad = 8;           // around the footer's content
constexpr int kRowHeight = 22;    // one legend row
constexpr int kSwatchWidth = 26;  // the line / marker drawn before a label
constexpr int kEntryGap = 16;     // between legend entries

cv::Scalar rgb(const sim::Rgb8& c) { return cv::Scalar(c[0], c[1], c[2]); }

enum class Swatch { kLine, kThinLine, kDisc, kCircle, kArrow };
struct Entry {
  Swatch swatch;
  sim::Rgb8 color;
  std::string text;
};

std::vector<Entry> legendEntries(const MapLegend& legend) {
  std::vector<Entry> entries = {
      {Swatch::kLine, kReferenceColor, "reference path"}};
  if (legend.agent_path)
    entries.push_back({Swatch::kThinLine, kAgentColor, "agent path"});
  entries.push_back({Swatch::kDisc, kStartColor, "start"});
  if (legend.goal) {
    entries.push_back({Swatch::kDisc, kGoalColor, "goal"});
    char radius[64];
    std::snprintf(radius, sizeof(radius), "success radius (%g m)",
                  static_cast<double>(legend.success_distance));
    entries.push_back({Swatch::kCircle, kGoalColor, radius});
  }
  if (legend.agent_path)
    entries.push_back({Swatch::kArrow, kAgentColor, "agent at the end"});
  if (legend.waypoints) {
    entries.push_back({Swatch::kDisc, kCandidateColor, "candidates"});
    entries.push_back({Swatch::kThinLine, kChosenColor, "chosen waypoint"});
  }
  return entries;
}

int textWidth(const std::string& text) {
  int baseline = 0;
  return cv::getTextSize(text, kFont, kFontScale, 1, &baseline).width;
}

std::string scaleText(float meters) {
  char text[32];
  std::snprintf(text, sizeof(text), "%g m", static_cast<double>(meters));
  return text;
}

// the scale bar's share of the footer: at most a quarter of the width
ScaleBar footerScaleBar(float metersPerPixel, int width) {
  return chooseScaleBar(metersPerPixel, std::clamp(width / 4, 8, 240));
}

// legend entries' positions (top-left of each entry's row slot), flowing
// left to right and wrapping within `available` pixels
struct Placed {
  int x = 0;
  int row = 0;
};
std::vector<Placed> layout(const std::vector<Entry>& entries, int available,
                           int* rows) {
  std::vector<Placed> placed;
  int x = 0, row = 0;
  for (const Entry& e : entries) {
    const int w = kSwatchWidth + 6 + textWidth(e.text);
    if (x > 0 && x + w > available) {
      x = 0;
      ++row;
    }
    placed.push_back({x, row});
    x += w + kEntryGap;
  }
  *rows = row + 1;
  return placed;
}

int legendWidth(int width, const ScaleBar& bar) {
  const int scaleRegion =
      std::max(bar.pixels, textWidth(scaleText(bar.meters))) + kPad;
  return std::max(1, width - 2 * kPad - scaleRegion);
}

}  // namespace

float MapStyle::metersPerPixel(const sim::Scene& scene, float floorY) const {
  if (meters_per_pixel > 0.0f) return meters_per_pixel;
  return sim::TopDownMap::metersPerPixelForLongSide(scene, floorY, long_side);
}

sim::TopDownMap drawEpisodeMap(const sim::Scene& scene,
                               const rollout::EpisodeRecord& record,
                               bool hasGoal, float successDistance,
                               const MapStyle& style) {
  VLN_CHECK_ARG(!record.positions.empty(), "drawEpisodeMap(): episode ",
                record.episode_id, " has no positions");
  const float floorY = record.positions.front().y();
  sim::TopDownMap map(scene, style.metersPerPixel(scene, floorY), floorY);
  // lines and markers keep their size in metres on large maps
  const float scale = std::max(1.0f, 0.05f / map.metersPerPixel());
  auto px = [&](float pixelsAt5cm) {
    return std::max(1, static_cast<int>(std::lround(pixelsAt5cm * scale)));
  };
  // reference under the agent's path, markers on top
  if (record.reference_path.size() >= 2)
    map.drawPath(record.reference_path, kReferenceColor, px(3));
  if (record.positions.size() >= 2)
    map.drawPath(record.positions, kAgentColor, px(2));
  if (hasGoal) {
    map.drawCircle(record.goal, successDistance, kGoalColor, px(2));
    map.drawPoint(record.goal, kGoalColor, px(5));
  }
  for (const rollout::WaypointChoice& choice : record.waypoint_choices) {
    for (const Vec3f& c : choice.candidates)
      map.drawPoint(c, kCandidateColor, px(2));
    if (choice.chosen >= 0 &&
        choice.chosen < static_cast<int>(choice.candidates.size()))
      map.drawPath({choice.position,
                    choice.candidates[static_cast<size_t>(choice.chosen)]},
                   kChosenColor, px(1));
  }
  map.drawPoint(record.positions.front(), kStartColor, px(5));
  const float heading = record.headings.empty() ? 0.0f : record.headings.back();
  map.drawAgent(record.positions.back(), heading, kAgentColor);
  return map;
}

MapLegend mapLegendOf(const rollout::EpisodeRecord& record, bool hasGoal,
                      float successDistance) {
  MapLegend legend{hasGoal, successDistance, /*agent_path=*/true};
  legend.waypoints = !record.waypoint_choices.empty();
  return legend;
}

ScaleBar chooseScaleBar(float metersPerPixel, int maxPixels) {
  VLN_CHECK_ARG(
      std::isfinite(metersPerPixel) && metersPerPixel > 0.0f && maxPixels > 0,
      "chooseScaleBar(): need a positive scale and length, got ",
      metersPerPixel, " m/pixel and ", maxPixels, " pixels");
  const double longest = static_cast<double>(metersPerPixel) * maxPixels;
  double best = 0.0;
  for (double power = std::pow(10.0, std::floor(std::log10(longest)) - 1);
       power <= longest; power *= 10.0)
    for (double step : {1.0, 2.0, 5.0})
      if (step * power <= longest * (1 + 1e-9))
        best = std::max(best, step * power);
  ScaleBar bar;
  bar.meters = static_cast<float>(best);
  bar.pixels =
      std::max(1, static_cast<int>(std::lround(best / metersPerPixel)));
  return bar;
}

int footerHeight(int width, float metersPerPixel, const MapLegend& legend) {
  int rows = 1;
  layout(legendEntries(legend),
         legendWidth(width, footerScaleBar(metersPerPixel, width)), &rows);
  return 2 * kPad + rows * kRowHeight;
}

Image mapImage(const sim::TopDownMap& map) {
  return Image{map.width(), map.height(), map.rgb()};
}

Image mapPicture(const sim::TopDownMap& map, const MapLegend& legend) {
  const int width = map.width();
  const ScaleBar bar = footerScaleBar(map.metersPerPixel(), width);
  const std::vector<Entry> entries = legendEntries(legend);
  int rows = 1;
  const std::vector<Placed> placed =
      layout(entries, legendWidth(width, bar), &rows);
  const int footer = 2 * kPad + rows * kRowHeight;

  Image out{width, map.height() + footer, {}};
  out.rgb.assign(static_cast<size_t>(out.width) * out.height * 3, 255);
  std::copy(map.rgb().begin(), map.rgb().end(), out.rgb.begin());
  cv::Mat canvas(out.height, out.width, CV_8UC3, out.rgb.data());
  const int top = map.height();
  cv::line(canvas, {0, top}, {width - 1, top}, cv::Scalar(180, 180, 180), 1);

  for (size_t i = 0; i < entries.size(); ++i) {
    const Entry& e = entries[i];
    const int x = kPad + placed[i].x;
    const int mid = top + kPad + placed[i].row * kRowHeight + kRowHeight / 2;
    const cv::Scalar color = rgb(e.color);
    switch (e.swatch) {
      case Swatch::kLine:
        cv::line(canvas, {x, mid}, {x + kSwatchWidth - 2, mid}, color, 3,
                 cv::LINE_AA);
        break;
      case Swatch::kThinLine:
        cv::line(canvas, {x, mid}, {x + kSwatchWidth - 2, mid}, color, 2,
                 cv::LINE_AA);
        break;
      case Swatch::kDisc:
        cv::circle(canvas, {x + kSwatchWidth / 2, mid}, 5, color, cv::FILLED,
                   cv::LINE_AA);
        break;
      case Swatch::kCircle:
        cv::circle(canvas, {x + kSwatchWidth / 2, mid}, 7, color, 2,
                   cv::LINE_AA);
        break;
      case Swatch::kArrow:
        cv::arrowedLine(canvas, {x + 2, mid}, {x + kSwatchWidth - 2, mid},
                        color, 2, cv::LINE_AA, 0, 0.4);
        break;
    }
    cv::putText(canvas, e.text, {x + kSwatchWidth + 6, mid + 5}, kFont,
                kFontScale, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  }

  // the scale bar, right-aligned on the first row: a bar with end ticks
  // and its length above it
  const int right = width - kPad;
  const int left = right - bar.pixels;
  const int y = top + kPad + kRowHeight - 4;
  cv::rectangle(canvas, {left, y - 3}, {right, y}, cv::Scalar(0, 0, 0),
                cv::FILLED);
  cv::line(canvas, {left, y - 8}, {left, y}, cv::Scalar(0, 0, 0), 1);
  cv::line(canvas, {right, y - 8}, {right, y}, cv::Scalar(0, 0, 0), 1);
  const std::string label = scaleText(bar.meters);
  cv::putText(canvas, label, {right - textWidth(label), y - 8}, kFont,
              kFontScale, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  return out;
}

std::string mapFileName(const std::string& prefix,
                        const std::string& episodeId) {
  return prefix + "episode_" + episodeId + "_map.png";
}

}  // namespace vln::viz
