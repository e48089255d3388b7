#pragma once
// Summary statistics of an episode file (and optionally its ground truth),
// for real R2R_VLNCE files and generated ones alike.

#include <array>
#include <cstdint>
#include <string>

#include <nlohmann/json_fwd.hpp>

#include "data/Episode.h"
#include "data/GroundTruth.h"
#include "sim/Agent.h"

namespace vln::data {

/// Counts and means over one episode file. Means are 0 when nothing
/// contributes to them (see the matching count).
struct DatasetStats {
  int64_t episodes = 0;
  int64_t scenes = 0;           ///< distinct scene_id values
  int64_t trajectories = 0;     ///< distinct trajectory_id values
  int64_t vocabulary_size = 0;  ///< num_vocab; 0 without instruction_vocab

  /// Instruction tokens excluding padding; from instruction_tokens when the
  /// file has them, else from tokenize(instruction_text).
  double mean_instruction_length = 0.0;
  int64_t max_instruction_length = 0;

  /// 3-D polyline length of reference_path (metres), over the episodes
  /// that have one.
  double mean_path_length = 0.0;
  int64_t episodes_with_path = 0;
  /// info.geodesic_distance (metres), over the episodes that have it.
  double mean_geodesic_distance = 0.0;
  int64_t episodes_with_geodesic = 0;

  /// Ground truth (only when given): episodes of the file with / without an
  /// entry, mean number of actions per matched episode and the action
  /// histogram over matched episodes, indexed by sim::Action code.
  bool has_ground_truth = false;
  int64_t ground_truth_matched = 0;
  int64_t ground_truth_missing = 0;
  double mean_ground_truth_actions = 0.0;
  std::array<int64_t, sim::kNumActions> action_counts{};
};

/// Statistics of `dataset`, with the ground-truth part when `groundTruth`
/// is non-null.
DatasetStats computeDatasetStats(const EpisodeDataset& dataset,
                                 const GroundTruth* groundTruth = nullptr);

/// 3-D length of a polyline (sum of segment lengths), metres.
double polylineLength(const std::vector<Vec3f>& points);

/// A human-readable multi-line report (one "name: value" per line; the
/// action distribution as counts and fractions).
std::string formatDatasetStats(const DatasetStats& stats);

/// The statistics as a JSON object (keys equal the member names).
nlohmann::json datasetStatsToJson(const DatasetStats& stats);

}  // namespace vln::data
