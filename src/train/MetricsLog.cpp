#include "train/MetricsLog.h"

#include <cerrno>
#include <chrono>
#include <cstring>

#include "common/Check.h"

namespace vln::train {

MetricsLog::MetricsLog(const std::filesystem::path& jsonlFile,
                       const std::filesystem::path& tensorboardDir)
    : jsonl_(jsonlFile) {
  if (jsonl_.has_parent_path())
    std::filesystem::create_directories(jsonl_.parent_path());
  out_ = std::fopen(jsonl_.c_str(), "a");
  VLN_CHECK_IO(out_ != nullptr, "MetricsLog: cannot open '", jsonl_.string(),
               "': ", std::strerror(errno));
  if (!tensorboardDir.empty())
    tensorboard_ = std::make_unique<TensorBoardWriter>(tensorboardDir);
}

MetricsLog::~MetricsLog() {
  if (out_) std::fclose(out_);
}

void MetricsLog::write(
    const std::string& type, nlohmann::json record,
    const std::vector<std::pair<std::string, double>>& scalars, int64_t step) {
  record["type"] = type;
  record["time"] = std::chrono::duration<double>(
                       std::chrono::system_clock::now().time_since_epoch())
                       .count();
  // non-finite numbers are not JSON: dump() writes them as null
  const std::string line = record.dump() + "\n";
  const bool ok =
      std::fwrite(line.data(), 1, line.size(), out_) == line.size() &&
      std::fflush(out_) == 0;
  VLN_CHECK_IO(ok, "MetricsLog: cannot write '", jsonl_.string(),
               "': ", std::strerror(errno));
  if (tensorboard_) tensorboard_->addScalars(step, scalars);
}

void MetricsLog::writeImage(const std::string& tag, int64_t step,
                            const std::string& encoded, int width, int height,
                            int channels) {
  if (tensorboard_)
    tensorboard_->addImage(tag, step, encoded, width, height, channels);
}

}  // namespace vln::train
