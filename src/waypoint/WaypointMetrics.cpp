#include "waypoint/WaypointMetrics.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>

#include <nlohmann/json.hpp>

namespace vln::waypoint {

namespace {

double horizontal(const Vec3f& a, const Vec3f& b) {
  return std::hypot(static_cast<double>(a.x() - b.x()),
                    static_cast<double>(a.z() - b.z()));
}

double ratio(double num, int64_t den) {
  return den > 0 ? num / static_cast<double>(den) : 0.0;
}

}  // namespace

NodeScore scoreCandidates(const std::vector<Candidate>& candidates,
                          const NodeTargets& targets) {
  NodeScore score;
  score.candidates = static_cast<int>(candidates.size());
  score.targets = static_cast<int>(targets.targets.size());
  std::vector<Vec3f> predicted;
  for (const Candidate& c : candidates) {
    if (isOpen(targets.open[static_cast<size_t>(c.heading_bin)],
               c.distance_bin))
      ++score.open;
    predicted.push_back(fromPolar(targets.agent, c.heading, c.distance));
  }
  if (predicted.empty() || targets.targets.empty()) return score;

  // nearest distances both ways
  const double inf = std::numeric_limits<double>::infinity();
  std::vector<double> toTarget(predicted.size(), inf);
  std::vector<double> toPrediction(targets.targets.size(), inf);
  for (size_t i = 0; i < predicted.size(); ++i)
    for (size_t j = 0; j < targets.targets.size(); ++j) {
      const double d = horizontal(predicted[i], targets.targets[j].position);
      toTarget[i] = std::min(toTarget[i], d);
      toPrediction[j] = std::min(toPrediction[j], d);
    }
  const auto mean = [](const std::vector<double>& v) {
    double sum = 0.0;
    for (double x : v) sum += x;
    return sum / static_cast<double>(v.size());
  };
  score.scored = true;
  score.chamfer = 0.5 * (mean(toTarget) + mean(toPrediction));
  score.hausdorff =
      std::max(*std::max_element(toTarget.begin(), toTarget.end()),
               *std::max_element(toPrediction.begin(), toPrediction.end()));
  return score;
}

void PredictorMetrics::add(const NodeScore& score) {
  ++nodes;
  candidates += score.candidates;
  open += score.open;
  targets += score.targets;
  abs_delta_sum += std::abs(score.candidates - score.targets);
  if (score.candidates == 0) ++empty;
  if (score.scored) {
    ++scored;
    chamfer_sum += score.chamfer;
    hausdorff_sum += score.hausdorff;
  }
}

void PredictorMetrics::merge(const PredictorMetrics& other) {
  nodes += other.nodes;
  candidates += other.candidates;
  open += other.open;
  targets += other.targets;
  scored += other.scored;
  empty += other.empty;
  chamfer_sum += other.chamfer_sum;
  hausdorff_sum += other.hausdorff_sum;
  abs_delta_sum += other.abs_delta_sum;
}

double PredictorMetrics::candidatesPerNode() const {
  return ratio(static_cast<double>(candidates), nodes);
}
double PredictorMetrics::targetsPerNode() const {
  return ratio(static_cast<double>(targets), nodes);
}
double PredictorMetrics::meanDelta() const {
  return ratio(static_cast<double>(candidates - targets), nodes);
}
double PredictorMetrics::meanAbsDelta() const {
  return ratio(static_cast<double>(abs_delta_sum), nodes);
}
double PredictorMetrics::openShare() const {
  return ratio(static_cast<double>(open), candidates);
}
double PredictorMetrics::meanChamfer() const {
  return ratio(chamfer_sum, scored);
}
double PredictorMetrics::meanHausdorff() const {
  return ratio(hausdorff_sum, scored);
}

nlohmann::json PredictorMetrics::toJson() const {
  return {{"nodes", nodes},
          {"candidates", candidates},
          {"open", open},
          {"targets", targets},
          {"scored", scored},
          {"empty", empty},
          {"candidates_per_node", candidatesPerNode()},
          {"targets_per_node", targetsPerNode()},
          {"delta", meanDelta()},
          {"abs_delta", meanAbsDelta()},
          {"open_share", openShare()},
          {"chamfer", meanChamfer()},
          {"hausdorff", meanHausdorff()}};
}

}  // namespace vln::waypoint
