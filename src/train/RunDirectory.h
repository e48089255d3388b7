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

/// For --resume: reads <dir>/config.yaml and throws std::invalid_argument
/// listing every differing key (with both values) that is not both in
/// resumeSafeKeys() and in `explicitKeys`. Throws when the directory holds
/// no run. Returns the keys that differ (and were allowed).
std::vector<std::string> checkResumeConfig(
    const std::filesystem::path& dir, const ExperimentConfig& requested,
    const std::vector<std::string>& explicitKeys);

}  // namespace vln::train
