#pragma once
// A run directory (output.dir) and the rules for starting and resuming:
//   config.yaml          the resolved config (written before anything else)
//   train.log            the log (console + file)
//   metrics.jsonl        one JSON object per update/epoch/evaluation
//   tb/                  TensorBoard event files
//   store/               the feature store (LMDB)
//   checkpoints/         ckpt.<i>.pth, best.json
//   eval/                stats files of the periodic evaluations
//   finished.json        written when training ends (reason, checkpoint)
//   train.lock           held by the training process (RunDirectoryLock)
//
// A fresh run refuses a non-empty directory. --resume requires the
// directory's config.yaml to equal the requested config, except for keys in
// resumeSafeKeys() that the user explicitly overrode (--set) this time:
// those only change speed, logging or how long training goes on, never what
// the data or the gradients are.

#include <filesystem>
#include <string>
#include <vector>

#include "train/ExperimentConfig.h"

namespace vln::train {

/// Every key path of `config` with its value as YAML text
/// ("trainer.lr" -> "0.00025"), in visit order.
std::vector<std::pair<std::string, std::string>> flattenConfig(
    const ExperimentConfig& config);

/// Key paths whose values differ between `a` and `b`.
std::vector<std::string> configDifferences(const ExperimentConfig& a,
                                           const ExperimentConfig& b);

/// Keys that may change on --resume when given explicitly with --set:
/// thread counts, logging, eval output extras, the device, the epoch /
/// iteration counts (to extend a run), patience and fault limits, the store
/// map size, the distributed timeouts and bucket size.
const std::vector<std::string>& resumeSafeKeys();

/// The key paths set by "section.key=value" overrides.
std::vector<std::string> overriddenKeys(
    const std::vector<std::string>& overrides);

/// Throws std::invalid_argument when a fresh run would start in a non-empty
/// `dir` (naming it and suggesting --resume).
void checkFreshRunDirectory(const std::filesystem::path& dir);

/// Holds <dir>/train.lock under an exclusive flock(2) for its lifetime, so
/// that a second train process on the same run directory (a --resume typed
/// beside a run still going) stops at once instead of interleaving its
/// checkpoints, store and metrics.jsonl with the first one's. The kernel
/// drops the lock with the process, kill -9 included; the file stays and
/// holds the last holder's pid for the message.
class RunDirectoryLock {
 public:
  /// Throws std::invalid_argument naming `dir` and the holder's pid when
  /// another process holds the lock, std::runtime_error when the lock file
  /// cannot be opened. `dir` must exist.
  explicit RunDirectoryLock(const std::filesystem::path& dir);
  ~RunDirectoryLock();
  RunDirectoryLock(const RunDirectoryLock&) = delete;
  RunDirectoryLock& operator=(const RunDirectoryLock&) = delete;

 private:
  int fd_ = -1;
};

/// For --resume: reads <dir>/config.yaml and throws std::invalid_argument
/// listing every differing key (with both values) that is not both in
/// resumeSafeKeys() and in `explicitKeys`. Throws when the directory holds
/// no run. Returns the keys that differ (and were allowed).
std::vector<std::string> checkResumeConfig(
    const std::filesystem::path& dir, const ExperimentConfig& requested,
    const std::vector<std::string>& explicitKeys);

}  // namespace vln::train
