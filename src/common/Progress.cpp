#include "common/Progress.h"

#include <spdlog/spdlog.h>

#include <algorithm>

namespace vln::common {

ProgressLine::ProgressLine(std::string label, int64_t total, std::string unit,
                           double intervalSeconds)
    : label_(std::move(label)),
      total_(total),
      unit_(std::move(unit)),
      interval_(intervalSeconds) {}

void ProgressLine::advance(int64_t count) {
  done_ += count;
  double now = clock_.seconds();
  if (now - lastLog_ >= interval_ || done_ >= total_) {
    lastLog_ = now;
    log();
  }
}

double ProgressLine::rate() const {
  double s = clock_.seconds();
  return s > 0 ? static_cast<double>(done_) / s : 0.0;
}

void ProgressLine::log() const {
  double r = rate();
  double remaining =
      r > 0 ? static_cast<double>(std::max<int64_t>(total_ - done_, 0)) / r : 0;
  int minutes = static_cast<int>(remaining) / 60;
  int seconds = static_cast<int>(remaining) % 60;
  double pct = total_ > 0 ? 100.0 * static_cast<double>(done_) /
                                static_cast<double>(total_)
                          : 100.0;
  spdlog::info("{}: {}/{} ({:.0f}%) {:.1f} {}/s, ETA {:02d}:{:02d}", label_,
               done_, total_, pct, r, unit_, minutes, seconds);
}

}  // namespace vln::common
