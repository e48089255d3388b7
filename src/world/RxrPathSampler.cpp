#include "world/RxrPathSampler.h"

#include <algorithm>
#include <cmath>
#include <set>

#include "common/Random.h"

namespace vln::world {

std::optional<GraphPath> sampleRxrWalk(const data::NavGraph& graph,
                                       const RxrTrajectoryConfig& config,
                                       uint64_t seed) {
  config.validate();
  if (graph.numNodes() < config.min_nodes) return std::nullopt;
  std::mt19937_64 rng(seed);
  const int target =
      config.min_nodes +
      common::uniformIndex(rng, config.max_nodes - config.min_nodes + 1);
  GraphPath path = {common::uniformIndex(rng, graph.numNodes())};
  std::vector<bool> visited(static_cast<size_t>(graph.numNodes()), false);
  visited[static_cast<size_t>(path.front())] = true;
  const float cosMaxTurn = std::cos(config.max_turn * kPi / 180.0f);

  // horizontal unit direction from node a to node b (zero when stacked)
  const auto direction = [&](int a, int b) {
    const Vec3f d = graph.node(b).position - graph.node(a).position;
    Eigen::Vector2f h(d.x(), d.z());
    const float n = h.norm();
    return n > 1e-6f ? Eigen::Vector2f(h / n) : Eigen::Vector2f::Zero();
  };

  // extend by unvisited neighbours that keep within the turn limit
  std::vector<int> options;
  while (static_cast<int>(path.size()) < target) {
    const int last = path.back();
    options.clear();
    for (const int next : graph.neighbors(last)) {
      if (visited[static_cast<size_t>(next)]) continue;
      if (path.size() >= 2 &&
          direction(path[path.size() - 2], last).dot(direction(last, next)) <
              cosMaxTurn - 1e-6f)
        continue;
      options.push_back(next);
    }
    if (options.empty()) return std::nullopt;
    const int next = options[static_cast<size_t>(
        common::uniformIndex(rng, static_cast<int>(options.size())))];
    visited[static_cast<size_t>(next)] = true;
    path.push_back(next);
  }

  // long enough, and ending away from the start
  const double length = pathLength(graph, path);
  const Vec3f span =
      graph.node(path.back()).position - graph.node(path.front()).position;
  if (length < config.min_length || length > config.max_length ||
      std::hypot(span.x(), span.z()) < config.min_goal_distance)
    return std::nullopt;
  return path;
}

int roomsVisited(const sim::SceneSemantics& semantics,
                 const std::vector<Vec3f>& waypoints) {
  std::set<int> rooms;
  for (const Vec3f& p : waypoints) {
    const int room = semantics.roomAt(p);
    if (room >= 0) rooms.insert(room);
  }
  return static_cast<int>(rooms.size());
}

}  // namespace vln::world
