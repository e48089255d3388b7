#pragma once
// Training metrics, written two ways: JSON lines (<run>/metrics.jsonl, one
// object per record with "type", appended and flushed at once so a kill
// loses nothing already logged) and, when enabled, TensorBoard scalars and
// images (<run>/tb/events.out.tfevents.*).

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "train/TensorBoardWriter.h"

namespace vln::train {

class MetricsLog {
 public:
  /// Appends to `jsonlFile`; TensorBoard files go to `tensorboardDir`
  /// (empty: none). Throws std::runtime_error naming a file it cannot open.
  MetricsLog(const std::filesystem::path& jsonlFile,
             const std::filesystem::path& tensorboardDir);
  ~MetricsLog();
  MetricsLog(const MetricsLog&) = delete;
  MetricsLog& operator=(const MetricsLog&) = delete;

  /// Writes `record` (a JSON object; "type" and "time" are added) as one
  /// line and the numeric `scalars` (tag, value) to TensorBoard at `step`.
  void write(const std::string& type, nlohmann::json record,
             const std::vector<std::pair<std::string, double>>& scalars,
             int64_t step);

  /// True when TensorBoard events are written.
  bool tensorboard() const { return tensorboard_ != nullptr; }
  /// Writes an encoded image (PNG picture or GIF video, see
  /// TensorBoardWriter::addImage()) to TensorBoard at `step`; nothing
  /// without TensorBoard.
  void writeImage(const std::string& tag, int64_t step,
                  const std::string& encoded, int width, int height,
                  int channels);

 private:
  std::filesystem::path jsonl_;
  std::FILE* out_ = nullptr;
  std::unique_ptr<TensorBoardWriter> tensorboard_;
};

}  // namespace vln::train
