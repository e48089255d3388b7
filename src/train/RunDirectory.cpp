#include "train/RunDirectory.h"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cstring>
#include <map>
#include <sstream>

#include "common/Check.h"
#include "common/Config.h"

namespace vln::train {
namespace {

// records every field as text under its dotted key path
class FlattenVisitor : public common::ConfigVisitor {
 public:
  std::vector<std::pair<std::string, std::string>> values;

  void field(std::string_view key, bool& v, std::string_view) override {
    add(key, v ? "true" : "false");
  }
  void field(std::string_view key, int& v, std::string_view,
             common::Bounds) override {
    add(key, std::to_string(v));
  }
  void field(std::string_view key, int64_t& v, std::string_view,
             common::Bounds) override {
    add(key, std::to_string(v));
  }
  void field(std::string_view key, double& v, std::string_view,
             common::Bounds) override {
    add(key, number(v));
  }
  void field(std::string_view key, float& v, std::string_view,
             common::Bounds) override {
    add(key, number(v));
  }
  void field(std::string_view key, std::string& v, std::string_view) override {
    add(key, "'" + v + "'");
  }
  void field(std::string_view key, std::vector<std::string>& v,
             std::string_view) override {
    std::string text = "[";
    for (size_t i = 0; i < v.size(); ++i)
      text += (i ? ", '" : "'") + v[i] + "'";
    add(key, text + "]");
  }
  void field(std::string_view key, std::vector<int>& v, std::string_view,
             common::Bounds) override {
    std::string text = "[";
    for (size_t i = 0; i < v.size(); ++i)
      text += (i ? ", " : "") + std::to_string(v[i]);
    add(key, text + "]");
  }
  void field(std::string_view key, std::vector<double>& v, std::string_view,
             common::Bounds) override {
    std::string text = "[";
    for (size_t i = 0; i < v.size(); ++i)
      text += (i ? ", " : "") + number(v[i]);
    add(key, text + "]");
  }
  void choice(std::string_view key, std::string& v,
              const std::vector<std::string>&, std::string_view) override {
    add(key, v);
  }
  void beginSection(std::string_view key, std::string_view) override {
    path_.emplace_back(key);
  }
  void endSection() override { path_.pop_back(); }

 private:
  // the shortest text that reads back to the same value
  template <class T>
  static std::string number(T v) {
    char buffer[64];
    auto result = std::to_chars(buffer, buffer + sizeof(buffer), v);
    return std::string(buffer, result.ptr);
  }
  void add(std::string_view key, std::string value) {
    std::string full;
    for (const auto& p : path_) full += p + ".";
    values.emplace_back(full + std::string(key), std::move(value));
  }
  std::vector<std::string> path_;
};

}  // namespace

std::vector<std::pair<std::string, std::string>> flattenConfig(
    const ExperimentConfig& config) {
  ExperimentConfig copy = config;
  FlattenVisitor visitor;
  copy.visit(visitor);
  return visitor.values;
}

std::vector<std::string> configDifferences(const ExperimentConfig& a,
                                           const ExperimentConfig& b) {
  const auto fa = flattenConfig(a);
  const auto fb = flattenConfig(b);
  VLN_ASSERT(fa.size() == fb.size());
  std::vector<std::string> keys;
  for (size_t i = 0; i < fa.size(); ++i)
    if (fa[i].second != fb[i].second) keys.push_back(fa[i].first);
  return keys;
}

const std::vector<std::string>& resumeSafeKeys() {
  static const std::vector<std::string> keys = {
      "trainer.torch_threads",
      "trainer.env_threads",
      "trainer.num_envs",
      "trainer.log_every_updates",
      "trainer.epochs",
      "trainer.dagger_iterations",
      "trainer.early_stopping_patience",
      "trainer.max_nonfinite_updates",
      "trainer.store_max_gib",
      "output.log_level",
      "output.tensorboard",
      "output.keep_checkpoints",
      "eval.num_envs",
      "eval.threads",
      "eval.save_episodes",
      "eval.map_episodes",
      "eval.video_episodes",
      "eval.tensorboard_maps",
      "eval.tensorboard_videos",
      "model.device",
      "trainer.distributed_timeout_s",
      "trainer.distributed_wait_s",
      "trainer.distributed_bucket_mib"};
  return keys;
}

std::vector<std::string> overriddenKeys(
    const std::vector<std::string>& overrides) {
  std::vector<std::string> keys;
  for (const auto& o : overrides) {
    const auto eq = o.find('=');
    keys.push_back(o.substr(0, eq));
  }
  return keys;
}

void checkFreshRunDirectory(const std::filesystem::path& dir) {
  std::error_code ec;
  if (!std::filesystem::exists(dir, ec)) return;
  VLN_CHECK_ARG(std::filesystem::is_directory(dir, ec), "train: output.dir '",
                dir.string(), "' exists and is not a directory");
  VLN_CHECK_ARG(
      std::filesystem::is_empty(dir, ec), "train: the run directory '",
      dir.string(),
      "' is not empty: pass --resume to continue that run, or choose another "
      "output.dir (--set output.dir=...)");
}

RunDirectoryLock::RunDirectoryLock(const std::filesystem::path& dir) {
  const std::filesystem::path file = dir / "train.lock";
  fd_ = ::open(file.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  VLN_CHECK_IO(fd_ >= 0, "train: cannot open the lock file '", file.string(),
               "': ", std::strerror(errno));
  if (::flock(fd_, LOCK_EX | LOCK_NB) != 0) {
    const int error = errno;
    char holder[32] = {};
    const ssize_t n = ::pread(fd_, holder, sizeof(holder) - 1, 0);
    std::string pid = n > 0 ? std::string(holder, static_cast<size_t>(n)) : "";
    pid.erase(std::remove(pid.begin(), pid.end(), '\n'), pid.end());
    ::close(fd_);
    fd_ = -1;
    VLN_CHECK_ARG(error != EWOULDBLOCK, "train: the run directory '",
                  dir.string(), "' is in use by another train process",
                  pid.empty() ? std::string() : " (pid " + pid + ")",
                  ": wait for it to end, or stop it before --resume");
    VLN_CHECK_IO(false, "train: cannot lock '", file.string(),
                 "': ", std::strerror(error));
  }
  const std::string mine = std::to_string(::getpid()) + "\n";
  // the pid only serves the message above: a failed write costs nothing
  const bool noted =
      ::ftruncate(fd_, 0) == 0 && ::pwrite(fd_, mine.data(), mine.size(), 0) ==
                                      static_cast<ssize_t>(mine.size());
  static_cast<void>(noted);
}

RunDirectoryLock::~RunDirectoryLock() {
  if (fd_ >= 0) ::close(fd_);  // closing releases the flock
}

std::vector<std::string> checkResumeConfig(
    const std::filesystem::path& dir, const ExperimentConfig& requested,
    const std::vector<std::string>& explicitKeys) {
  const auto file = dir / "config.yaml";
  VLN_CHECK_ARG(std::filesystem::exists(file), "train --resume: '",
                dir.string(), "' holds no run to resume (", file.string(),
                " is missing)");
  // the stored config is the resolved one, so output.dir is in it too
  const ExperimentConfig stored = loadExperimentConfig(file);
  const auto a = flattenConfig(stored);
  const auto b = flattenConfig(requested);
  std::vector<std::string> allowed;
  std::ostringstream refused;
  int refusedCount = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    if (a[i].second == b[i].second) continue;
    const std::string& key = a[i].first;
    const bool safe =
        std::count(resumeSafeKeys().begin(), resumeSafeKeys().end(), key) > 0;
    const bool explicitlySet =
        std::count(explicitKeys.begin(), explicitKeys.end(), key) > 0;
    if (safe && explicitlySet) {
      allowed.push_back(key);
      continue;
    }
    ++refusedCount;
    refused << "\n  " << key << ": run has " << a[i].second << ", requested "
            << b[i].second
            << (safe ? " (may change on resume only when given with --set)"
                     : "");
  }
  VLN_CHECK_ARG(refusedCount == 0,
                "train --resume: the config differs from the run's ",
                file.string(), " in ", refusedCount, " key(s):", refused.str());
  return allowed;
}

}  // namespace vln::train
