#include "data/DatasetStats.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstdio>
#include <set>

namespace vln::data {

double polylineLength(const std::vector<Vec3f>& points) {
  double length = 0.0;
  for (size_t i = 1; i < points.size(); ++i)
    length += static_cast<double>((points[i] - points[i - 1]).norm());
  return length;
}

DatasetStats computeDatasetStats(const EpisodeDataset& dataset,
                                 const GroundTruth* groundTruth) {
  DatasetStats stats;
  stats.episodes = static_cast<int64_t>(dataset.episodes.size());
  if (dataset.instruction_vocab)
    stats.vocabulary_size = dataset.instruction_vocab->size();
  const int pad =
      dataset.instruction_vocab ? dataset.instruction_vocab->padIndex() : 0;

  // per-episode sums, divided once at the end
  std::set<std::string> scenes;
  std::set<int> trajectories;
  double instructionSum = 0.0;
  double pathSum = 0.0;
  double geodesicSum = 0.0;
  double actionSum = 0.0;
  for (const Episode& episode : dataset.episodes) {
    scenes.insert(episode.scene_id);
    trajectories.insert(episode.trajectory_id);

    const auto& tokens = episode.instruction.instruction_tokens;
    int64_t length =
        tokens.empty()
            ? static_cast<int64_t>(
                  tokenize(episode.instruction.instruction_text).size())
            : unpaddedLength(tokens, pad);
    instructionSum += static_cast<double>(length);
    stats.max_instruction_length =
        std::max(stats.max_instruction_length, length);

    if (!episode.reference_path.empty()) {
      pathSum += polylineLength(episode.reference_path);
      ++stats.episodes_with_path;
    }
    if (episode.geodesic_distance) {
      geodesicSum += *episode.geodesic_distance;
      ++stats.episodes_with_geodesic;
    }

    if (!groundTruth) continue;
    auto it = groundTruth->find(episode.episode_id);
    if (it == groundTruth->end()) {
      ++stats.ground_truth_missing;
      continue;
    }
    ++stats.ground_truth_matched;
    actionSum += static_cast<double>(it->second.actions.size());
    for (sim::Action action : it->second.actions)
      ++stats.action_counts[static_cast<size_t>(action)];
  }

  stats.scenes = static_cast<int64_t>(scenes.size());
  stats.trajectories = static_cast<int64_t>(trajectories.size());
  auto mean = [](double sum, int64_t count) {
    return count > 0 ? sum / static_cast<double>(count) : 0.0;
  };
  stats.mean_instruction_length = mean(instructionSum, stats.episodes);
  stats.mean_path_length = mean(pathSum, stats.episodes_with_path);
  stats.mean_geodesic_distance =
      mean(geodesicSum, stats.episodes_with_geodesic);
  stats.has_ground_truth = groundTruth != nullptr;
  stats.mean_ground_truth_actions = mean(actionSum, stats.ground_truth_matched);
  return stats;
}

std::string formatDatasetStats(const DatasetStats& stats) {
  std::string out;
  auto line = [&out](const char* name, const std::string& value) {
    char buffer[64];
    std::snprintf(buffer, sizeof(buffer), "%-28s ", name);
    out += buffer;
    out += value;
    out += '\n';
  };
  auto fixed = [](double value, int digits) {
    char buffer[64];
    std::snprintf(buffer, sizeof(buffer), "%.*f", digits, value);
    return std::string(buffer);
  };
  line("episodes:", std::to_string(stats.episodes));
  line("scenes:", std::to_string(stats.scenes));
  line("trajectories:", std::to_string(stats.trajectories));
  line("vocabulary size:", stats.vocabulary_size > 0
                               ? std::to_string(stats.vocabulary_size)
                               : std::string("none"));
  line("mean instruction length:",
       fixed(stats.mean_instruction_length, 2) + " tokens (max " +
           std::to_string(stats.max_instruction_length) + ")");
  line("mean path length:",
       stats.episodes_with_path > 0
           ? fixed(stats.mean_path_length, 3) + " m over " +
                 std::to_string(stats.episodes_with_path) + " episodes"
           : std::string("no reference paths"));
  line("mean geodesic distance:",
       stats.episodes_with_geodesic > 0
           ? fixed(stats.mean_geodesic_distance, 3) + " m over " +
                 std::to_string(stats.episodes_with_geodesic) + " episodes"
           : std::string("no geodesic distances"));
  if (!stats.has_ground_truth) return out;

  line("ground truth:",
       std::to_string(stats.ground_truth_matched) + " episodes matched, " +
           std::to_string(stats.ground_truth_missing) + " missing");
  line("mean ground-truth actions:", fixed(stats.mean_ground_truth_actions, 2));
  int64_t total = 0;
  for (int64_t count : stats.action_counts) total += count;
  for (int a = 0; a < sim::kNumActions; ++a) {
    int64_t count = stats.action_counts[static_cast<size_t>(a)];
    std::string name =
        "  " + std::string(sim::actionName(static_cast<sim::Action>(a))) + ":";
    double fraction = total > 0 ? static_cast<double>(count) / total : 0.0;
    line(name.c_str(),
         std::to_string(count) + " (" + fixed(100.0 * fraction, 1) + "%)");
  }
  return out;
}

nlohmann::json datasetStatsToJson(const DatasetStats& stats) {
  nlohmann::json value = {
      {"episodes", stats.episodes},
      {"scenes", stats.scenes},
      {"trajectories", stats.trajectories},
      {"vocabulary_size", stats.vocabulary_size},
      {"mean_instruction_length", stats.mean_instruction_length},
      {"max_instruction_length", stats.max_instruction_length},
      {"mean_path_length", stats.mean_path_length},
      {"episodes_with_path", stats.episodes_with_path},
      {"mean_geodesic_distance", stats.mean_geodesic_distance},
      {"episodes_with_geodesic", stats.episodes_with_geodesic},
      {"has_ground_truth", stats.has_ground_truth},
  };
  if (stats.has_ground_truth) {
    value["ground_truth_matched"] = stats.ground_truth_matched;
    value["ground_truth_missing"] = stats.ground_truth_missing;
    value["mean_ground_truth_actions"] = stats.mean_ground_truth_actions;
    nlohmann::json actions = nlohmann::json::object();
    for (int a = 0; a < sim::kNumActions; ++a)
      actions[std::string(sim::actionName(static_cast<sim::Action>(a)))] =
          stats.action_counts[static_cast<size_t>(a)];
    value["action_counts"] = std::move(actions);
  }
  return value;
}

}  // namespace vln::data
