#pragma once
// R2R-style trajectories on a nav-graph: shortest paths (by Euclidean edge
// length) between node pairs whose length and node count fall in the
// configured ranges. R2R sampled its paths this way: shortest paths of at
// least 5 m with 4-6 edges (Anderson et al. 2018), about 10 m long.

#include <cstdint>
#include <vector>

#include "data/NavGraph.h"
#include "world/WorldConfig.h"

namespace vln::world {

/// A trajectory through a nav-graph: node indices from start to goal.
using GraphPath = std::vector<int>;

/// Enumerates every admissible trajectory of one graph once, then hands them
/// out in a seeded order so that splits can draw disjoint sets.
class TrajectorySampler {
 public:
  /// Enumerates the candidates of `graph`:
  /// for every ordered pair (start, goal), the shortest path when its node
  /// count is in [min_nodes, max_nodes] and its length in [min_length,
  /// max_length] metres. Candidates are ordered by (start, goal). The
  /// sampler keeps no reference to `graph`.
  TrajectorySampler(const data::NavGraph& graph,
                    const TrajectoryConfig& config);

  /// Number of candidate trajectories.
  int size() const { return static_cast<int>(candidates_.size()); }
  /// Candidate `index` (0 <= index < size()).
  const GraphPath& candidate(int index) const;
  /// All candidates, ordered by (start, goal).
  const std::vector<GraphPath>& candidates() const { return candidates_; }
  /// Candidate indices in a random order fixed by `seed`.
  std::vector<int> shuffledOrder(uint64_t seed) const;
  /// Up to `count` distinct candidates, the first `count` of
  /// shuffledOrder(seed).
  std::vector<GraphPath> sample(int count, uint64_t seed) const;

 private:
  std::vector<GraphPath> candidates_;
};

/// Length of `path` along its edges (sum of Euclidean node distances),
/// metres.
double pathLength(const data::NavGraph& graph, const GraphPath& path);

}  // namespace vln::world
