#include "data/Split.h"

namespace vln::data {

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

}  // namespace vln::data
