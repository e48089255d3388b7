#include "data/Split.h"

namespace vln::data {

Split loadSplit(const std::filesystem::path& root, const std::string& name,
                int cap) {
  Split split;
  split.name = name;
  split.episodes = readEpisodes(splitEpisodesPath(root, name)).episodes;
  keepEvenlySpaced(split.episodes, cap);
  for (const Episode& e : split.episodes)
    if (!e.goals.empty()) split.hasGoals = true;
  const std::filesystem::path gt = splitGroundTruthPath(root, name);
  if (split.hasGoals && std::filesystem::exists(gt))
    split.groundTruth = std::make_unique<GroundTruth>(readGroundTruth(gt));
  return split;
}

}  // namespace vln::data
