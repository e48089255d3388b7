#pragma once
// A progress line with rate and ETA, logged at most every `intervalSeconds`.

#include <chrono>
#include <cstdint>
#include <string>

namespace vln::common {

/// Monotonic wall-clock stopwatch in seconds.
class Stopwatch {
 public:
  Stopwatch() : start_(std::chrono::steady_clock::now()) {}
  /// Seconds since construction or the last reset().
  double seconds() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() -
                                         start_)
        .count();
  }
  void reset() { start_ = std::chrono::steady_clock::now(); }

 private:
  std::chrono::steady_clock::time_point start_;
};

/// Logs "<label>: done/total (pct) rate unit/s, ETA mm:ss" through spdlog.
class ProgressLine {
 public:
  ProgressLine(std::string label, int64_t total, std::string unit,
               double intervalSeconds = 5.0);
  /// Advances by `count` and logs when the interval has passed or at the end.
  void advance(int64_t count = 1);
  /// Items completed so far.
  int64_t done() const { return done_; }
  /// Items per second since construction.
  double rate() const;

 private:
  void log() const;
  std::string label_;
  int64_t total_;
  std::string unit_;
  double interval_;
  int64_t done_ = 0;
  Stopwatch clock_;
  double lastLog_ = 0.0;
};

}  // namespace vln::common
