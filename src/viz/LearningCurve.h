#pragma once
// The learning curve of a training run: the trainer's periodic validation
// (the "eval" records of <run>/metrics.jsonl, train/PeriodicEvaluator.h)
// read back and drawn as a PNG with two panels side by side, SR and SPL of
// one split (val_unseen by default) against the wall time of training
// (left) and against the optimizer updates (right), with ticks, axis
// labels, a legend and the best checkpoint by SPL marked.
//
// Wall time is training time: the seconds from the start of the process
// that wrote a record (its "start" record, minus that record's
// setup_seconds), plus the whole span of every earlier process of a resumed
// run (first to last record), so the time a run spent killed does not
// count. Files written before "start" records existed count from their
// first record, minus its "seconds" when that is a collection round's.
// Updates are an "eval" record's "updates" or, in older files, the sum of
// the "epoch" records' updates up to the checkpoint's epoch (checkpoint i
// is saved after epoch i + 1).

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "viz/Image.h"

namespace vln::viz {

/// One validation of the run.
struct CurvePoint {
  int checkpoint = 0;    ///< index of the evaluated checkpoint
  int64_t updates = 0;   ///< optimizer updates behind it
  double seconds = 0.0;  ///< wall time of training when evaluated, s
  double success = 0.0;  ///< SR
  double spl = 0.0;      ///< SPL
  int num_episodes = 0;  ///< episodes the means are over
};

/// The validations of one split, by checkpoint (a checkpoint evaluated
/// twice, e.g. again after a resume, keeps its last record).
struct LearningCurve {
  std::string split;
  std::vector<CurvePoint> points;
};

/// Reads the "eval" records of `split` from a trainer's metrics.jsonl.
/// Empty lines and an unterminated last line (a writer killed mid-line) are
/// skipped. Throws std::runtime_error when the file cannot be read and
/// std::invalid_argument naming the file and the line for a line that is
/// not a JSON object, a record without a string "type", and a record whose
/// fields this reader uses are missing or not numbers; and naming the file
/// and the split when no record is of that split.
LearningCurve readLearningCurve(const std::filesystem::path& metricsFile,
                                const std::string& split = "val_unseen");

/// Size and title of the picture.
struct CurveStyle {
  int width = 1280;   ///< pixels, >= 400
  int height = 520;   ///< pixels, >= 240
  std::string title;  ///< above the panels; empty: "<split> learning curve"
};

/// One axis of a panel: its range, its ticks (nice numbers: 1, 2 or 5 times
/// a power of ten apart, from `min` to `max`) and its label.
struct CurveAxis {
  double min = 0.0;
  double max = 1.0;
  std::vector<double> ticks;
  std::string label;
};

/// A pixel of the picture (x right, y down).
struct CurvePixel {
  int x = 0;
  int y = 0;
};

/// One panel: its plot area in pixels (`left`..`right` x `top`..`bottom`,
/// inclusive) and its axes.
struct CurvePanel {
  int left = 0;
  int top = 0;
  int right = 0;
  int bottom = 0;
  CurveAxis x;
  CurveAxis y;
  /// Where the point (x, y) in axis units is drawn (rounded; points outside
  /// the axes map outside the plot area).
  CurvePixel toPixel(double x, double y) const;
};

/// The panels of a picture: wall time in minutes (hours beyond 3 hours)
/// on the left, updates on the right, both from 0; both y axes run from 0
/// to a nice number at or above 1.05 x the largest SR or SPL (at most 1).
struct CurveLayout {
  int width = 0;
  int height = 0;
  CurvePanel time;
  CurvePanel updates;
  bool hours = false;  ///< the time axis is in hours, not minutes

  /// A point's x in the time panel's unit (minutes or hours).
  double timeValue(const CurvePoint& point) const;
};

/// The layout drawLearningCurve() uses for `curve` (which needs a point).
/// Throws std::invalid_argument for an empty curve or a style below the
/// minimum size.
CurveLayout layoutLearningCurve(const LearningCurve& curve,
                                const CurveStyle& style = {});

/// Colours of the two series (RGB).
inline constexpr uint8_t kSuccessRgb[3] = {30, 100, 220};
inline constexpr uint8_t kSplRgb[3] = {235, 120, 20};

/// The picture: per panel, grid lines at the ticks, SR and SPL as lines
/// with a filled disc (SR) or square (SPL) of 9 pixels at every point, the
/// best checkpoint by SPL ringed; the title, a legend and the axis labels.
Image drawLearningCurve(const LearningCurve& curve,
                        const CurveStyle& style = {});

/// Reads `metricsFile`, draws `split`'s curve and saves it as a PNG at
/// `out` (atomically); returns the curve drawn.
LearningCurve saveLearningCurve(const std::filesystem::path& metricsFile,
                                const std::filesystem::path& out,
                                const std::string& split = "val_unseen",
                                const CurveStyle& style = {});

}  // namespace vln::viz
