#pragma once
// One split of an R2R_VLNCE dataset as the trainer and the evaluator load
// it: its episodes, capped, and its ground truth.

#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "data/Episode.h"
#include "data/GroundTruth.h"

namespace vln::data {

struct Split {
  std::string name;
  std::vector<Episode> episodes;
  /// <name>_gt.json.gz when it exists and the split has goals; null else.
  std::unique_ptr<GroundTruth> groundTruth;
  /// Some episode has a goal (false for a test split without them).
  bool hasGoals = false;
  /// The file's instruction_vocab, when it has one (what the tokens mean).
  std::optional<Vocabulary> vocabulary;
};

/// Reads split `name` under `root` (splitEpisodesPath()), keeps `cap`
/// episodes spread evenly over the file (keepEvenlySpaced(); -1: all) and
/// its ground truth (splitGroundTruthPath()) when present and needed. An
/// empty split is not an error here; callers that need episodes say so.
/// Throws what readEpisodes() and readGroundTruth() throw.
Split loadSplit(const std::filesystem::path& root, const std::string& name,
                int cap);

}  // namespace vln::data
