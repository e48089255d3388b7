#pragma once
// One split of an R2R_VLNCE dataset as the trainer and the evaluator load
// it: its episodes, capped, and its ground truth; and the hidden goals of a
// split published without them (the local leaderboard of the test split).
//
// Hidden files (written by world::generateWorld() for the test split, read
// only by the eval binary's --test-ground-truth, never by the trainer):
//   <root>/hidden/<split>/<split>_goals.json.gz  the split's episodes as an
//       episode file (Episode.h) with goals, info and reference_path, as
//       val_unseen's file has them
//   <root>/hidden/<split>/<split>_gt.json.gz     its ground truth
//       (GroundTruth.h)

#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "data/DatasetConfig.h"
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
  /// The goals and the ground truth came from hidden files
  /// (attachHiddenGoals()), e.g. a test split scored locally.
  bool hiddenGoals = false;
};

/// The two hidden files of one split.
struct HiddenSplitFiles {
  std::filesystem::path goals;         ///< <split>_goals.json.gz
  std::filesystem::path ground_truth;  ///< <split>_gt.json.gz
};

/// Reads split `name` under `root` (splitEpisodesPath()), keeps `cap`
/// episodes spread evenly over the file (keepEvenlySpaced(); -1: all) and
/// its ground truth (splitGroundTruthPath()) when present and needed. An
/// empty split is not an error here; callers that need episodes say so.
/// Throws what readEpisodes() and readGroundTruth() throw.
Split loadSplit(const std::filesystem::path& root, const std::string& name,
                int cap);

/// Split `name` of the dataset `dataset` names: loadSplit() of data_path
/// for format r2r; for format rxr the episodes of readRxrEpisodes() with
/// dataset.rxr_filter, capped like loadSplit(), and, when they have goals,
/// the ground truth of the filter's roles (readRxrGroundTruth()) when every
/// role's file exists. Throws what those readers throw.
Split loadDatasetSplit(const DatasetConfig& dataset, const std::string& name,
                       int cap);

/// The ground-truth file(s) of split `name` of `dataset`, in the order they
/// are read: <split>_gt.json.gz (r2r) or one per rxr_filter role (rxr).
std::vector<std::filesystem::path> datasetGroundTruthPaths(
    const DatasetConfig& dataset, const std::string& name);

/// `root / "hidden" / split / (split + "_goals.json.gz")`.
std::filesystem::path hiddenGoalsPath(const std::filesystem::path& root,
                                      std::string_view split);

/// `root / "hidden" / split / (split + "_gt.json.gz")`.
std::filesystem::path hiddenGroundTruthPath(const std::filesystem::path& root,
                                            std::string_view split);

/// The hidden files of `split` from what a user names: either file, the
/// folder holding them (hidden/<split>), the hidden/ folder or the dataset
/// root. Throws std::runtime_error naming `given` and the paths looked at
/// when it does not exist or holds neither file, and naming the missing file
/// when only one of the two is there.
HiddenSplitFiles findHiddenFiles(const std::filesystem::path& given,
                                 std::string_view split);

/// Gives every episode of `split` (loaded without goals) its goals,
/// info.geodesic_distance and reference_path from `files.goals`, and the
/// split its ground truth from `files.ground_truth` (only its episodes');
/// sets hasGoals and hiddenGoals. Throws what readEpisodes() and
/// readGroundTruth() throw for a missing or malformed file, and
/// std::invalid_argument naming the file, the split and the episode when the
/// split already has goals, when an episode is missing from either file or
/// has no goal there, or when the goals file's episode is another one (its
/// scene, start or instruction differ: a file of another world).
void attachHiddenGoals(Split& split, const HiddenSplitFiles& files);

/// The same for an RxR split (dataset.format rxr): its hidden copy is an RxR
/// split folder, <split>_<role>.json.gz with goals and
/// <split>_<role>_gt.json.gz for every role of `filter`, under `given` =
/// the dataset root, its hidden/ folder or hidden/<split> (where
/// world::generateRxrWorld() writes test_challenge's). Throws
/// std::runtime_error naming `given` and the folders looked at when none
/// holds the split's files, and what attachHiddenGoals() throws for
/// episodes that do not match.
void attachHiddenRxrGoals(Split& split, const std::filesystem::path& given,
                          const RxrFilterConfig& filter);

}  // namespace vln::data
