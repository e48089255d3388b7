#include "data/Split.h"

#include <map>
#include <stdexcept>

#include "common/Check.h"
#include "data/RxrEpisodes.h"

namespace vln::data {

namespace fs = std::filesystem;

namespace {

// how a hidden episode differs from the split's episode of the same id
// ("its scene_id ... differs ..."), "" when it does not
std::string difference(const Episode& hidden, const Episode& published) {
  if (hidden.scene_id != published.scene_id)
    return strCat("its scene_id '", hidden.scene_id,
                  "' differs from the split's '", published.scene_id, "'");
  for (const auto& [differs, field] :
       {std::pair{hidden.start_position != published.start_position,
                  "start_position"},
        std::pair{hidden.start_rotation != published.start_rotation,
                  "start_rotation"},
        std::pair{hidden.instruction.instruction_text !=
                      published.instruction.instruction_text,
                  "instruction.instruction_text"}})
    if (differs) return strCat("its ", field, " differs from the split's");
  return "";
}

}  // namespace

Split loadSplit(const std::filesystem::path& root, const std::string& name,
                int cap) {
  Split split;
  split.name = name;
  EpisodeDataset dataset = readEpisodes(splitEpisodesPath(root, name));
  split.episodes = std::move(dataset.episodes);
  split.vocabulary = std::move(dataset.instruction_vocab);
  keepEvenlySpaced(split.episodes, cap);
  for (const Episode& e : split.episodes)
    if (!e.goals.empty()) split.hasGoals = true;
  const std::filesystem::path gt = splitGroundTruthPath(root, name);
  if (split.hasGoals && std::filesystem::exists(gt))
    split.groundTruth = std::make_unique<GroundTruth>(readGroundTruth(gt));
  return split;
}

Split loadDatasetSplit(const DatasetConfig& dataset, const std::string& name,
                       int cap) {
  if (!dataset.isRxr()) return loadSplit(dataset.data_path, name, cap);
  Split split;
  split.name = name;
  split.episodes = readRxrEpisodes(dataset.data_path, name, dataset.rxr_filter);
  keepEvenlySpaced(split.episodes, cap);
  for (const Episode& e : split.episodes)
    if (!e.goals.empty()) split.hasGoals = true;
  // like R2R, a split may ship without ground truth (test_challenge)
  bool allFiles = true;
  for (const auto& file : datasetGroundTruthPaths(dataset, name))
    allFiles = allFiles && std::filesystem::exists(file);
  if (split.hasGoals && allFiles)
    split.groundTruth = std::make_unique<GroundTruth>(readRxrGroundTruth(
        dataset.data_path, name, dataset.rxr_filter.resolvedRoles()));
  return split;
}

std::vector<std::filesystem::path> datasetGroundTruthPaths(
    const DatasetConfig& dataset, const std::string& name) {
  if (!dataset.isRxr()) return {splitGroundTruthPath(dataset.data_path, name)};
  std::vector<std::filesystem::path> files;
  for (const std::string& role : dataset.rxr_filter.resolvedRoles())
    files.push_back(rxrGroundTruthPath(dataset.data_path, name, role));
  return files;
}

std::filesystem::path hiddenGoalsPath(const std::filesystem::path& root,
                                      std::string_view split) {
  return root / "hidden" / split / (std::string(split) + "_goals.json.gz");
}

std::filesystem::path hiddenGroundTruthPath(const std::filesystem::path& root,
                                            std::string_view split) {
  return root / "hidden" / split / (std::string(split) + "_gt.json.gz");
}

HiddenSplitFiles findHiddenFiles(const std::filesystem::path& given,
                                 std::string_view split) {
  const std::string goalsName = std::string(split) + "_goals.json.gz";
  const std::string truthName = std::string(split) + "_gt.json.gz";
  VLN_CHECK_IO(fs::exists(given), "findHiddenFiles(): '", given.string(),
               "' does not exist");

  // a file names its folder; a folder is hidden/<split>, hidden/ or the
  // dataset root
  std::vector<fs::path> folders;
  if (fs::is_directory(given)) {
    folders = {given, given / split, given / "hidden" / split};
  } else {
    const std::string name = given.filename().string();
    VLN_CHECK_ARG(name == goalsName || name == truthName,
                  "findHiddenFiles(): '", given.string(),
                  "' is not a hidden file of split '", split, "' (expected ",
                  goalsName, " or ", truthName, ", or a folder holding them)");
    folders = {given.parent_path()};
  }
  std::string looked;
  for (const fs::path& folder : folders) {
    const fs::path goals = folder / goalsName;
    const fs::path truth = folder / truthName;
    const bool hasGoals = fs::exists(goals);
    const bool hasTruth = fs::exists(truth);
    if (hasGoals && hasTruth) return {goals, truth};
    VLN_CHECK_IO(!hasTruth, "findHiddenFiles(): '", goals.string(),
                 "' does not exist (the goals of split '", split,
                 "' beside its ground truth '", truth.string(), "')");
    VLN_CHECK_IO(!hasGoals, "findHiddenFiles(): '", truth.string(),
                 "' does not exist (the ground truth of split '", split,
                 "' beside its goals '", goals.string(), "')");
    looked += (looked.empty() ? "'" : ", '") + folder.string() + "'";
  }
  throw std::runtime_error(strCat("findHiddenFiles(): '", given.string(),
                                  "' holds no hidden files of split '", split,
                                  "' (looked for ", goalsName, " and ",
                                  truthName, " in ", looked, ")"));
}

namespace {

// the goals of `hidden` (read from `goalsSource`) and the ground truth
// `truth` (from `truthSource`) given to the episodes of `split`
void attachGoals(Split& split, const std::vector<Episode>& hidden,
                 const GroundTruth& truth, const std::string& goalsSource,
                 const std::string& truthSource) {
  std::map<int, const Episode*> byId;
  for (const Episode& e : hidden) byId[e.episode_id] = &e;

  // every episode of the split, checked before any is changed
  std::vector<Episode> episodes = split.episodes;
  auto groundTruth = std::make_unique<GroundTruth>();
  for (Episode& e : episodes) {
    const std::string where =
        strCat("attachHiddenGoals(): '", goalsSource, "': episode ",
               e.episode_id, " of split '", split.name, "'");
    const auto it = byId.find(e.episode_id);
    VLN_CHECK_ARG(it != byId.end(), where,
                  " is missing: the file does not cover the split");
    const Episode& h = *it->second;
    const std::string differs = difference(h, e);
    VLN_CHECK_ARG(differs.empty(), where, " is another episode: ", differs,
                  " (hidden files of another dataset?)");
    VLN_CHECK_ARG(!h.goals.empty(), where, " has no goals");
    const auto gt = truth.find(e.episode_id);
    VLN_CHECK_ARG(gt != truth.end(), "attachHiddenGoals(): '",
                  truthSource, "': episode ", e.episode_id,
                  " of split '", split.name,
                  "' is missing: the file does not cover the split");
    e.goals = h.goals;
    e.geodesic_distance = h.geodesic_distance;
    e.reference_path = h.reference_path;
    groundTruth->emplace(e.episode_id, gt->second);
  }
  split.episodes = std::move(episodes);
  split.groundTruth = std::move(groundTruth);
  split.hasGoals = !split.episodes.empty();
  split.hiddenGoals = true;
}

}  // namespace

void attachHiddenGoals(Split& split, const HiddenSplitFiles& files) {
  VLN_CHECK_ARG(!split.hasGoals, "attachHiddenGoals(): split '", split.name,
                "' already has goals; hidden goals ('", files.goals.string(),
                "') are for a split published without them");
  // the goals first: their errors are the ones to report
  const EpisodeDataset hidden = readEpisodes(files.goals);
  const GroundTruth truth = readGroundTruth(files.ground_truth);
  attachGoals(split, hidden.episodes, truth, files.goals.string(),
              files.ground_truth.string());
}

void attachHiddenRxrGoals(Split& split, const std::filesystem::path& given,
                          const RxrFilterConfig& filter) {
  VLN_CHECK_ARG(!split.hasGoals, "attachHiddenRxrGoals(): split '",
                split.name, "' already has goals; hidden goals ('",
                given.string(), "') are for a split published without them");
  VLN_CHECK_IO(fs::exists(given), "attachHiddenRxrGoals(): '", given.string(),
               "' does not exist");
  const std::vector<std::string> roles = filter.resolvedRoles();
  VLN_CHECK_ARG(!roles.empty(), "attachHiddenRxrGoals(): no roles to read");
  // the folder whose <split>/ holds the hidden files: the dataset root's
  // hidden/, hidden/ itself, or the parent of hidden/<split>; a folder with
  // episodes but no ground truth is the published split, not its hidden copy
  std::string looked;
  for (const fs::path& root :
       {given / "hidden", given, given.parent_path()}) {
    if (!fs::exists(rxrEpisodesPath(root, split.name, roles.front())) ||
        !fs::exists(rxrGroundTruthPath(root, split.name, roles.front()))) {
      looked += (looked.empty() ? "'" : ", '") + (root / split.name).string() + "'";
      continue;
    }
    const std::vector<Episode> hidden = readRxrEpisodes(root, split.name, filter);
    const GroundTruth truth = readRxrGroundTruth(root, split.name, roles);
    const std::string source = (root / split.name).string();
    attachGoals(split, hidden, truth, source, source);
    return;
  }
  throw std::runtime_error(strCat(
      "attachHiddenRxrGoals(): '", given.string(),
      "' holds no hidden RxR files of split '", split.name, "' (looked for ",
      rxrEpisodesPath("", split.name, roles.front()).filename().string(),
      " in ", looked, ")"));
}

}  // namespace vln::data
