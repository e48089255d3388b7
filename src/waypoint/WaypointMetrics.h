#pragma once
// The candidate-waypoint predictor metrics of Hong et al. (CVPR 2022, Table
// 1; their waypoint predictor's eval.py), per node and summed over nodes:
//
//  - candidates: waypoints predicted per panorama (at most 5 after NMS);
//    delta = candidates - targets, averaged signed (their eval.py) and
//    absolute (|delta|, a mismatch that signs cannot cancel).
//  - %Open: share of predicted waypoints whose cell is open space (the
//    node's open distance along the candidate's heading reaches its
//    distance; WaypointTargets.h step 2).
//  - d_C (Chamfer): 0.5 * (mean over predictions of the distance to the
//    nearest target + mean over targets of the distance to the nearest
//    prediction), metres, horizontal.
//  - d_H (Hausdorff): the larger of the two directed maxima of those
//    nearest distances, metres.
//
// Predictions sit at their cells' centres, targets at the neighbours' true
// transferred positions, as in their evaluation. A node without any
// prediction has no d_C or d_H (their code would fail); it is counted in
// `empty` and left out of those two means.

#include <cstdint>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "waypoint/WaypointHeatmap.h"
#include "waypoint/WaypointTargets.h"

namespace vln::waypoint {

/// The metrics of one node.
struct NodeScore {
  int candidates = 0;
  int open = 0;  ///< candidates in open space
  int targets = 0;
  bool scored = false;     ///< at least one candidate and one target
  double chamfer = 0.0;    ///< d_C, metres (scored nodes)
  double hausdorff = 0.0;  ///< d_H, metres (scored nodes)
};

/// Scores `candidates` (relative to targets.agent) against the node's
/// targets and open space.
NodeScore scoreCandidates(const std::vector<Candidate>& candidates,
                          const NodeTargets& targets);

/// Sums of NodeScore over nodes, and the means the paper reports.
struct PredictorMetrics {
  int64_t nodes = 0;
  int64_t candidates = 0;
  int64_t open = 0;
  int64_t targets = 0;
  int64_t scored = 0;
  int64_t empty = 0;  ///< nodes without a candidate
  double chamfer_sum = 0.0;
  double hausdorff_sum = 0.0;
  int64_t abs_delta_sum = 0;  ///< sum of |candidates - targets|

  void add(const NodeScore& score);
  void merge(const PredictorMetrics& other);
  double candidatesPerNode() const;  ///< mean candidates per panorama
  double targetsPerNode() const;
  double meanDelta() const;      ///< mean (candidates - targets)
  double meanAbsDelta() const;   ///< mean |candidates - targets|
  double openShare() const;      ///< %Open as a share in [0, 1]
  double meanChamfer() const;    ///< d_C over scored nodes, metres
  double meanHausdorff() const;  ///< d_H over scored nodes, metres
  /// Counts and means as a JSON object.
  nlohmann::json toJson() const;
};

}  // namespace vln::waypoint
