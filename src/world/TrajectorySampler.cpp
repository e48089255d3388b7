#include "world/TrajectorySampler.h"

#include <algorithm>
#include <functional>
#include <limits>
#include <queue>
#include <utility>

#include "common/Check.h"
#include "common/Random.h"

namespace vln::world {

namespace {

// Dijkstra from `source` over Euclidean edge weights; `previous` gives the
// shortest-path tree (-1 at the source and unreachable nodes). Ties keep the
// first-found predecessor, and neighbours are visited in ascending index
// order, so the tree is deterministic.
void shortestPathTree(const data::NavGraph& graph, int source,
                      std::vector<double>& distance,
                      std::vector<int>& previous) {
  const auto n = static_cast<size_t>(graph.numNodes());
  distance.assign(n, std::numeric_limits<double>::infinity());
  previous.assign(n, -1);
  using Entry = std::pair<double, int>;
  std::priority_queue<Entry, std::vector<Entry>, std::greater<>> queue;
  distance[static_cast<size_t>(source)] = 0.0;
  queue.emplace(0.0, source);
  while (!queue.empty()) {
    const auto [d, u] = queue.top();
    queue.pop();
    if (d > distance[static_cast<size_t>(u)]) continue;
    for (const int v : graph.neighbors(u)) {
      const double candidate = d + graph.euclidean(u, v);
      if (candidate < distance[static_cast<size_t>(v)]) {
        distance[static_cast<size_t>(v)] = candidate;
        previous[static_cast<size_t>(v)] = u;
        queue.emplace(candidate, v);
      }
    }
  }
}

}  // namespace

TrajectorySampler::TrajectorySampler(const data::NavGraph& graph,
                                     const TrajectoryConfig& config) {
  config.validate();
  std::vector<double> distance;
  std::vector<int> previous;
  for (int start = 0; start < graph.numNodes(); ++start) {
    shortestPathTree(graph, start, distance, previous);
    for (int goal = 0; goal < graph.numNodes(); ++goal) {
      const double length = distance[static_cast<size_t>(goal)];
      if (goal == start || length < config.min_length ||
          length > config.max_length)
        continue;
      // walk the tree back from the goal, giving up once it is too long
      GraphPath path;
      for (int v = goal;
           v >= 0 && static_cast<int>(path.size()) <= config.max_nodes;
           v = previous[static_cast<size_t>(v)])
        path.push_back(v);
      const int nodes = static_cast<int>(path.size());
      if (nodes < config.min_nodes || nodes > config.max_nodes ||
          path.back() != start)
        continue;
      std::reverse(path.begin(), path.end());
      candidates_.push_back(std::move(path));
    }
  }
}

const GraphPath& TrajectorySampler::candidate(int index) const {
  VLN_ASSERT(index >= 0 && index < size());
  return candidates_[static_cast<size_t>(index)];
}

std::vector<int> TrajectorySampler::shuffledOrder(uint64_t seed) const {
  std::vector<int> order(candidates_.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = static_cast<int>(i);
  std::mt19937_64 rng(seed);
  common::deterministicShuffle(order, rng);
  return order;
}

std::vector<GraphPath> TrajectorySampler::sample(int count,
                                                 uint64_t seed) const {
  std::vector<GraphPath> paths;
  for (const int index : shuffledOrder(seed)) {
    if (static_cast<int>(paths.size()) >= count) break;
    paths.push_back(candidate(index));
  }
  return paths;
}

double pathLength(const data::NavGraph& graph, const GraphPath& path) {
  double length = 0.0;
  for (size_t i = 1; i < path.size(); ++i)
    length += graph.euclidean(path[i - 1], path[i]);
  return length;
}

}  // namespace vln::world
