#include "viz/LearningCurve.h"

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <optional>

#include "common/Check.h"
#include "common/FileIo.h"

namespace vln::viz {

namespace {

namespace fs = std::filesystem;

// ---------------------------------------------------------------------------
// reading

// one line's record, with errors naming the file and the line
class Record {
 public:
  Record(const nlohmann::json& json, std::string where)
      : json_(json), where_(std::move(where)) {}

  const std::string& where() const { return where_; }
  bool has(const char* key) const { return json_.contains(key); }

  double number(const char* key) const {
    const auto it = json_.find(key);
    VLN_CHECK_ARG(it != json_.end(), where_, ": field '", key, "' is missing");
    VLN_CHECK_ARG(it->is_number() && std::isfinite(it->get<double>()), where_,
                  ": field '", key, "' must be a finite number, got ",
                  it->dump());
    return it->get<double>();
  }

  int64_t integer(const char* key) const {
    const double value = number(key);
    VLN_CHECK_ARG(value == std::floor(value) && std::abs(value) < 9e15, where_,
                  ": field '", key, "' must be an integer, got ",
                  json_.at(key).dump());
    return static_cast<int64_t>(value);
  }

  std::string string(const char* key) const {
    const auto it = json_.find(key);
    VLN_CHECK_ARG(it != json_.end(), where_, ": field '", key, "' is missing");
    VLN_CHECK_ARG(it->is_string(), where_, ": field '", key,
                  "' must be a string, got ", it->dump());
    return it->get<std::string>();
  }

 private:
  const nlohmann::json& json_;
  std::string where_;
};

// ---------------------------------------------------------------------------
// axes

// the smallest 1, 2 or 5 x 10^k step that divides [0, top] into at most
// `maxTicks` intervals
double niceStep(double top, int maxTicks) {
  const double rough = top / maxTicks;
  const double power = std::pow(10.0, std::floor(std::log10(rough)));
  for (const double step : {1.0, 2.0, 5.0, 10.0})
    if (step * power * maxTicks >= top * (1 - 1e-9)) return step * power;
  return 10.0 * power;
}

// [0, nice number >= top] with its ticks; `fallback` when top is not > 0
CurveAxis axisUpTo(double top, double fallback, int maxTicks, double cap,
                   std::string label) {
  CurveAxis axis;
  axis.label = std::move(label);
  if (!(top > 0.0)) top = fallback;
  const double step = niceStep(top, maxTicks);
  axis.max = std::min(std::ceil(top / step - 1e-9) * step, cap);
  for (int k = 0; k * step <= axis.max * (1 + 1e-9); ++k)
    axis.ticks.push_back(k * step);
  return axis;
}

// a tick's text: as many decimals as the step needs
std::string tickText(double value, double step) {
  const int decimals =
      step >= 1.0 ? 0 : static_cast<int>(std::ceil(-std::log10(step) - 1e-9));
  char text[32];
  std::snprintf(text, sizeof(text), "%.*f", decimals, value);
  return text;
}

// ---------------------------------------------------------------------------
// drawing

constexpr int kFont = cv::FONT_HERSHEY_SIMPLEX;
constexpr double kFontScale = 0.5;
constexpr double kTitleScale = 0.7;
const cv::Scalar kBlack(0, 0, 0);
const cv::Scalar kGrid(225, 225, 225);

// the canvas holds RGB bytes, so a Scalar is (r, g, b)
cv::Scalar color(const uint8_t (&rgb)[3]) {
  return cv::Scalar(rgb[0], rgb[1], rgb[2]);
}

cv::Size textSize(const std::string& text, double scale = kFontScale) {
  int baseline = 0;
  return cv::getTextSize(text, kFont, scale, 1, &baseline);
}

void text(cv::Mat& canvas, const std::string& s, cv::Point at,
          double scale = kFontScale) {
  cv::putText(canvas, s, at, kFont, scale, kBlack, 1, cv::LINE_AA);
}

cv::Point point(const CurvePixel& p) { return {p.x, p.y}; }

void drawAxes(cv::Mat& canvas, const CurvePanel& panel) {
  // grid lines and ticks at every tick, with their values
  const double xStep = panel.x.ticks.size() > 1 ? panel.x.ticks[1] : 1.0;
  const double yStep = panel.y.ticks.size() > 1 ? panel.y.ticks[1] : 1.0;
  for (const double t : panel.x.ticks) {
    const int x = panel.toPixel(t, 0.0).x;
    cv::line(canvas, {x, panel.top}, {x, panel.bottom}, kGrid, 1);
    cv::line(canvas, {x, panel.bottom}, {x, panel.bottom + 5}, kBlack, 1);
    const std::string label = tickText(t, xStep);
    text(canvas, label, {x - textSize(label).width / 2, panel.bottom + 20});
  }
  for (const double t : panel.y.ticks) {
    const int y = panel.toPixel(0.0, t).y;
    cv::line(canvas, {panel.left, y}, {panel.right, y}, kGrid, 1);
    cv::line(canvas, {panel.left - 5, y}, {panel.left, y}, kBlack, 1);
    const std::string label = tickText(t, yStep);
    const cv::Size size = textSize(label);
    text(canvas, label, {panel.left - 9 - size.width, y + size.height / 2});
  }
  // the axes, and their labels (x centred below, y above the plot)
  cv::line(canvas, {panel.left, panel.top}, {panel.left, panel.bottom}, kBlack,
           1);
  cv::line(canvas, {panel.left, panel.bottom}, {panel.right, panel.bottom},
           kBlack, 1);
  const int middle = (panel.left + panel.right) / 2;
  text(canvas, panel.x.label,
       {middle - textSize(panel.x.label).width / 2, panel.bottom + 45});
  text(canvas, panel.y.label, {panel.left - 50, panel.top - 12});
}

void drawMarker(cv::Mat& canvas, cv::Point at, bool square,
                const cv::Scalar& c) {
  if (square)
    cv::rectangle(canvas, {at.x - 4, at.y - 4}, {at.x + 4, at.y + 4}, c,
                  cv::FILLED);
  else
    cv::circle(canvas, at, 4, c, cv::FILLED, cv::LINE_AA);
}

// SR and SPL of `curve` in `panel`, x given by `xOf`; the best point ringed
template <class XOf>
void drawSeries(cv::Mat& canvas, const CurvePanel& panel,
                const LearningCurve& curve, size_t best, XOf xOf) {
  std::vector<size_t> order(curve.points.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    return xOf(curve.points[a]) < xOf(curve.points[b]);
  });
  std::vector<cv::Point> success, spl;
  for (const size_t i : order) {
    const CurvePoint& p = curve.points[i];
    success.push_back(point(panel.toPixel(xOf(p), p.success)));
    spl.push_back(point(panel.toPixel(xOf(p), p.spl)));
  }
  cv::polylines(canvas, success, false, color(kSuccessRgb), 2, cv::LINE_AA);
  cv::polylines(canvas, spl, false, color(kSplRgb), 2, cv::LINE_AA);
  for (const cv::Point& at : success)
    drawMarker(canvas, at, false, color(kSuccessRgb));
  for (const cv::Point& at : spl) drawMarker(canvas, at, true, color(kSplRgb));
  const CurvePoint& b = curve.points[best];
  cv::circle(canvas, point(panel.toPixel(xOf(b), b.spl)), 9, kBlack, 2,
             cv::LINE_AA);
}

// the legend: one entry per series and the best checkpoint
struct LegendEntry {
  std::string label;
  int kind;  // 0: SR, 1: SPL, 2: ring
};
constexpr int kSwatch = 30, kGap = 8, kSpace = 24;

std::vector<LegendEntry> legendEntries(const CurvePoint& best) {
  char bestText[96];
  std::snprintf(bestText, sizeof(bestText),
                "best SPL: ckpt %d (SR %.3f, SPL %.3f)", best.checkpoint,
                best.success, best.spl);
  return {{"SR", 0}, {"SPL", 1}, {bestText, 2}};
}

int legendWidth(const std::vector<LegendEntry>& entries) {
  int width = -kSpace;
  for (const LegendEntry& e : entries)
    width += kSwatch + kGap + textSize(e.label).width + kSpace;
  return width;
}

// right-aligned at `right`, text baseline `y`
void drawLegend(cv::Mat& canvas, int right, int y,
                const std::vector<LegendEntry>& entries) {
  int x = right - legendWidth(entries);
  for (const LegendEntry& e : entries) {
    const cv::Point mid(x + kSwatch / 2, y - 5);
    if (e.kind == 2) {
      cv::circle(canvas, mid, 9, kBlack, 2, cv::LINE_AA);
    } else {
      const cv::Scalar c = color(e.kind == 0 ? kSuccessRgb : kSplRgb);
      cv::line(canvas, {x, mid.y}, {x + kSwatch, mid.y}, c, 2, cv::LINE_AA);
      drawMarker(canvas, mid, e.kind == 1, c);
    }
    x += kSwatch + kGap;
    text(canvas, e.label, {x, y});
    x += textSize(e.label).width + kSpace;
  }
}

}  // namespace

// ===========================================================================
// public API
// ===========================================================================

LearningCurve readLearningCurve(const std::filesystem::path& metricsFile,
                                const std::string& split) {
  const std::string contents = common::readFile(metricsFile);
  LearningCurve curve;
  curve.split = split;

  // the wall time of training: this process's time since its start plus
  // the spans of the earlier processes of a resumed run
  double sessionStart = std::numeric_limits<double>::quiet_NaN();
  double lastTime = sessionStart;
  double before = 0.0;
  std::map<int64_t, int64_t> epochUpdates;  // epoch -> its updates
  std::map<int, CurvePoint> byCheckpoint;
  std::map<int, bool> hasUpdates;

  size_t begin = 0;
  for (int line = 1; begin < contents.size(); ++line) {
    const size_t end = contents.find('\n', begin);
    const bool terminated = end != std::string::npos;
    const std::string text =
        contents.substr(begin, terminated ? end - begin : std::string::npos);
    begin = terminated ? end + 1 : contents.size();
    if (text.find_first_not_of(" \t\r") == std::string::npos) continue;
    const std::string where =
        strCat("readLearningCurve(): '", metricsFile.string(), "':", line);
    const nlohmann::json json =
        nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
    if (!terminated && json.is_discarded()) break;  // killed mid-line
    VLN_CHECK_ARG(json.is_object(), where, ": not a JSON object: '",
                  text.substr(0, 80), text.size() > 80 ? "...'" : "'");
    const Record record(json, where);
    const std::string type = record.string("type");
    const double time = record.number("time");

    if (type == "start") {
      if (!std::isnan(sessionStart)) before += lastTime - sessionStart;
      sessionStart =
          time -
          (record.has("setup_seconds") ? record.number("setup_seconds") : 0.0);
    } else if (std::isnan(sessionStart)) {
      // a file from before "start" records: its first record, less the
      // collection round it reports
      sessionStart = time - (type == "collect" && record.has("seconds")
                                 ? record.number("seconds")
                                 : 0.0);
    }
    lastTime = time;

    if (type == "epoch")
      epochUpdates[record.integer("epoch")] = record.integer("updates");
    if (type != "eval" || record.string("split") != split) continue;
    CurvePoint p;
    p.checkpoint = static_cast<int>(record.integer("checkpoint"));
    p.success = record.number("success");
    p.spl = record.number("spl");
    p.num_episodes = record.has("num_episodes")
                         ? static_cast<int>(record.integer("num_episodes"))
                         : 0;
    p.seconds = before + time - sessionStart;
    hasUpdates[p.checkpoint] = record.has("updates");
    if (hasUpdates[p.checkpoint]) p.updates = record.integer("updates");
    byCheckpoint[p.checkpoint] = p;
  }
  VLN_CHECK_ARG(!byCheckpoint.empty(), "readLearningCurve(): '",
                metricsFile.string(), "' has no \"eval\" record of split '",
                split,
                "' (was the run validated on it? trainer.eval_during_training, "
                "eval.splits)");

  // older files: the updates of the epochs up to the checkpoint's
  for (auto& [index, p] : byCheckpoint) {
    if (!hasUpdates[index])
      for (const auto& [epoch, updates] : epochUpdates)
        if (epoch <= index + 1) p.updates += updates;
    curve.points.push_back(p);
  }
  return curve;
}

CurvePixel CurvePanel::toPixel(double xValue, double yValue) const {
  const double fx = (xValue - x.min) / (x.max - x.min);
  const double fy = (yValue - y.min) / (y.max - y.min);
  return {static_cast<int>(std::lround(left + fx * (right - left))),
          static_cast<int>(std::lround(bottom - fy * (bottom - top)))};
}

double CurveLayout::timeValue(const CurvePoint& point) const {
  return point.seconds / (hours ? 3600.0 : 60.0);
}

CurveLayout layoutLearningCurve(const LearningCurve& curve,
                                const CurveStyle& style) {
  VLN_CHECK_ARG(!curve.points.empty(),
                "layoutLearningCurve(): the curve of split '", curve.split,
                "' has no point");
  VLN_CHECK_ARG(style.width >= 400 && style.height >= 240,
                "layoutLearningCurve(): the picture must be at least 400 x "
                "240 pixels, got ",
                style.width, " x ", style.height);
  CurveLayout layout;
  layout.width = style.width;
  layout.height = style.height;

  // the ranges of the data
  double seconds = 0.0, updates = 0.0, value = 0.0;
  for (const CurvePoint& p : curve.points) {
    seconds = std::max(seconds, p.seconds);
    updates = std::max(updates, static_cast<double>(p.updates));
    value = std::max({value, p.success, p.spl});
  }
  layout.hours = seconds > 3 * 3600.0;
  const double timeTop = seconds / (layout.hours ? 3600.0 : 60.0);

  // two panels side by side, each with room for tick labels on its left,
  // the title and legend above and the x labels below
  const int half = style.width / 2;
  const std::string yLabel = curve.split + " SR, SPL";
  auto panel = [&](int x0, CurveAxis x) {
    CurvePanel p;
    p.left = x0 + 70;
    p.right = x0 + half - 25;
    p.top = 80;
    p.bottom = style.height - 60;
    p.x = std::move(x);
    // 5% headroom, so the best point does not sit on the frame
    p.y = axisUpTo(std::max(value * 1.05, 0.05), 0.1, 5, 1.0, yLabel);
    return p;
  };
  layout.time =
      panel(0, axisUpTo(timeTop, 1.0, 6, std::numeric_limits<double>::max(),
                        layout.hours ? "wall time of training (hours)"
                                     : "wall time of training (minutes)"));
  layout.updates =
      panel(half, axisUpTo(updates, 1.0, 6, std::numeric_limits<double>::max(),
                           "optimizer updates"));
  return layout;
}

Image drawLearningCurve(const LearningCurve& curve, const CurveStyle& style) {
  const CurveLayout layout = layoutLearningCurve(curve, style);
  Image image{layout.width, layout.height,
              std::vector<uint8_t>(
                  static_cast<size_t>(layout.width) * layout.height * 3, 255)};
  cv::Mat canvas(image.height, image.width, CV_8UC3, image.rgb.data());

  // the best checkpoint by SPL (ties: the earliest)
  size_t best = 0;
  for (size_t i = 1; i < curve.points.size(); ++i)
    if (curve.points[i].spl > curve.points[best].spl) best = i;

  // title and legend, the legend on a row of its own when both do not fit
  const std::string title =
      style.title.empty() ? curve.split + " learning curve" : style.title;
  text(canvas, title, {20, 30}, kTitleScale);
  const std::vector<LegendEntry> entries = legendEntries(curve.points[best]);
  const bool oneRow = 20 + textSize(title, kTitleScale).width + 40 +
                          legendWidth(entries) + 20 <=
                      layout.width;
  drawLegend(canvas, layout.width - 20, oneRow ? 30 : 54, entries);

  // the panels
  drawAxes(canvas, layout.time);
  drawAxes(canvas, layout.updates);
  drawSeries(canvas, layout.time, curve, best,
             [&](const CurvePoint& p) { return layout.timeValue(p); });
  drawSeries(canvas, layout.updates, curve, best, [](const CurvePoint& p) {
    return static_cast<double>(p.updates);
  });
  return image;
}

LearningCurve saveLearningCurve(const std::filesystem::path& metricsFile,
                                const std::filesystem::path& out,
                                const std::string& split,
                                const CurveStyle& style) {
  LearningCurve curve = readLearningCurve(metricsFile, split);
  savePng(drawLearningCurve(curve, style), out);
  return curve;
}

}  // namespace vln::viz
