#include "data/NavGraph.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <queue>

#include "common/Check.h"
#include "common/Json.h"

namespace vln::data {

// ---------------------------------------------------------------------------
// construction and lookup
// ---------------------------------------------------------------------------

int NavGraph::addNode(std::string id, const Vec3f& position) {
  VLN_CHECK_ARG(!id.empty(), "NavGraph::addNode(): empty node id");
  VLN_CHECK_ARG(position.allFinite(), "NavGraph::addNode(): node '", id,
                "' has a non-finite position");
  VLN_CHECK_ARG(!index_.contains(id),
                "NavGraph::addNode(): duplicate node id '", id, "'");
  const int index = numNodes();
  index_.emplace(id, index);
  nodes_.push_back({std::move(id), position});
  adjacency_.emplace_back();
  return index;
}

void NavGraph::addEdge(std::string_view a, std::string_view b) {
  const int ia = find(a);
  const int ib = find(b);
  VLN_CHECK_ARG(ia >= 0, "NavGraph::addEdge(): unknown node id '", a, "'");
  VLN_CHECK_ARG(ib >= 0, "NavGraph::addEdge(): unknown node id '", b, "'");
  VLN_CHECK_ARG(ia != ib, "NavGraph::addEdge(): self-loop on node '", a, "'");
  if (adjacent(ia, ib)) return;
  // keep neighbour lists sorted so iteration order (and thus tie-breaking
  // downstream) does not depend on the order edges were listed in
  auto insertSorted = [](std::vector<int>& list, int value) {
    list.insert(std::lower_bound(list.begin(), list.end(), value), value);
  };
  insertSorted(adjacency_[ia], ib);
  insertSorted(adjacency_[ib], ia);
  ++numEdges_;
}

const NavGraphNode& NavGraph::node(int index) const {
  VLN_ASSERT(index >= 0 && index < numNodes());
  return nodes_[index];
}

int NavGraph::find(std::string_view id) const {
  auto it = index_.find(std::string(id));
  return it == index_.end() ? -1 : it->second;
}

int NavGraph::indexOf(std::string_view id) const {
  const int index = find(id);
  VLN_CHECK_ARG(index >= 0, "NavGraph::indexOf(): no node with id '", id, "'");
  return index;
}

std::span<const int> NavGraph::neighbors(int index) const {
  VLN_ASSERT(index >= 0 && index < numNodes());
  return adjacency_[index];
}

bool NavGraph::adjacent(int a, int b) const {
  VLN_ASSERT(a >= 0 && a < numNodes() && b >= 0 && b < numNodes());
  return std::binary_search(adjacency_[a].begin(), adjacency_[a].end(), b);
}

std::vector<std::pair<int, int>> NavGraph::edges() const {
  std::vector<std::pair<int, int>> out;
  out.reserve(numEdges_);
  for (int a = 0; a < numNodes(); ++a)
    for (int b : adjacency_[a])
      if (a < b) out.emplace_back(a, b);
  return out;
}

// ---------------------------------------------------------------------------
// geometry and shortest paths
// ---------------------------------------------------------------------------

double NavGraph::euclidean(int a, int b) const {
  // double precision like R2R's numpy distances on float64 positions
  const Vec3d pa = node(a).position.cast<double>();
  const Vec3d pb = node(b).position.cast<double>();
  return (pa - pb).norm();
}

int NavGraph::nearestNode(const Vec3f& position) const {
  const Vec3d p = position.cast<double>();
  int best = -1;
  double bestDistance = std::numeric_limits<double>::infinity();
  for (int i = 0; i < numNodes(); ++i) {
    const double d = (nodes_[i].position.cast<double>() - p).norm();
    if (d < bestDistance) {
      bestDistance = d;
      best = i;
    }
  }
  return best;
}

void NavGraph::dijkstra(int from, std::vector<double>& dist,
                        std::vector<int>& previous) const {
  VLN_ASSERT(from >= 0 && from < numNodes());
  dist.assign(numNodes(), std::numeric_limits<double>::infinity());
  previous.assign(numNodes(), -1);
  using Item = std::pair<double, int>;
  std::priority_queue<Item, std::vector<Item>, std::greater<>> frontier;
  dist[from] = 0.0;
  frontier.emplace(0.0, from);
  while (!frontier.empty()) {
    auto [d, u] = frontier.top();
    frontier.pop();
    if (d > dist[u]) continue;  // stale queue entry
    for (int v : adjacency_[u]) {
      const double candidate = d + euclidean(u, v);
      if (candidate < dist[v]) {
        dist[v] = candidate;
        previous[v] = u;
        frontier.emplace(candidate, v);
      }
    }
  }
}

std::vector<double> NavGraph::distancesFrom(int from) const {
  std::vector<double> dist;
  std::vector<int> previous;
  dijkstra(from, dist, previous);
  return dist;
}

double NavGraph::distance(int a, int b) const {
  VLN_ASSERT(b >= 0 && b < numNodes());
  return distancesFrom(a)[b];
}

std::vector<int> NavGraph::shortestPath(int from, int to) const {
  VLN_ASSERT(to >= 0 && to < numNodes());
  std::vector<double> dist;
  std::vector<int> previous;
  dijkstra(from, dist, previous);
  if (!std::isfinite(dist[to])) return {};
  std::vector<int> path;
  for (int v = to; v != -1; v = previous[v]) path.push_back(v);
  std::reverse(path.begin(), path.end());
  return path;
}

// ---------------------------------------------------------------------------
// JSON
// ---------------------------------------------------------------------------

NavGraph navGraphFromJson(const nlohmann::json& json, std::string_view source) {
  const std::string where = std::string(source);
  VLN_CHECK_ARG(json.is_object(), where,
                ": expected a JSON object with 'nodes' and 'edges', got ",
                json.type_name());
  auto nodes = json.find("nodes");
  VLN_CHECK_ARG(nodes != json.end(), where, ": field 'nodes' is missing");
  VLN_CHECK_ARG(nodes->is_object(), where,
                ": field 'nodes' must map ids to [x, y, z], got ",
                nodes->type_name());
  auto edges = json.find("edges");
  VLN_CHECK_ARG(edges != json.end(), where, ": field 'edges' is missing");
  VLN_CHECK_ARG(edges->is_array(), where,
                ": field 'edges' must be an array of [id, id] pairs, got ",
                edges->type_name());

  // nodes
  NavGraph graph;
  for (const auto& [id, value] : nodes->items()) {
    VLN_CHECK_ARG(value.is_array() && value.size() == 3, where,
                  ": field 'nodes.", id, "' must be [x, y, z], got ",
                  value.dump());
    Vec3f position;
    for (int k = 0; k < 3; ++k) {
      VLN_CHECK_ARG(value[k].is_number(), where, ": field 'nodes.", id, "[", k,
                    "]' must be a number, got ", value[k].dump());
      position[k] = value[k].get<float>();
    }
    VLN_CHECK_ARG(position.allFinite() && !id.empty(), where, ": field 'nodes.",
                  id, "' is not a valid node, got ", value.dump());
    graph.addNode(id, position);
  }

  // edges
  for (size_t e = 0; e < edges->size(); ++e) {
    const auto& edge = (*edges)[e];
    VLN_CHECK_ARG(edge.is_array() && edge.size() == 2 && edge[0].is_string() &&
                      edge[1].is_string(),
                  where, ": field 'edges[", e, "]' must be [id, id], got ",
                  edge.dump());
    const auto a = edge[0].get<std::string>();
    const auto b = edge[1].get<std::string>();
    VLN_CHECK_ARG(graph.find(a) >= 0, where, ": field 'edges[", e,
                  "][0]' names unknown node '", a, "'");
    VLN_CHECK_ARG(graph.find(b) >= 0, where, ": field 'edges[", e,
                  "][1]' names unknown node '", b, "'");
    VLN_CHECK_ARG(a != b, where, ": field 'edges[", e, "]' is a self-loop on '",
                  a, "'");
    graph.addEdge(a, b);
  }
  return graph;
}

nlohmann::json navGraphToJson(const NavGraph& graph) {
  nlohmann::json nodes = nlohmann::json::object();
  for (int i = 0; i < graph.numNodes(); ++i) {
    const auto& n = graph.node(i);
    nodes[n.id] = {n.position.x(), n.position.y(), n.position.z()};
  }
  // sort by id pair so the file does not depend on insertion order
  std::vector<std::pair<std::string, std::string>> pairs;
  for (auto [a, b] : graph.edges()) {
    std::string ia = graph.node(a).id;
    std::string ib = graph.node(b).id;
    if (ib < ia) std::swap(ia, ib);
    pairs.emplace_back(std::move(ia), std::move(ib));
  }
  std::sort(pairs.begin(), pairs.end());
  nlohmann::json edges = nlohmann::json::array();
  for (auto& [a, b] : pairs) edges.push_back({a, b});
  return {{"nodes", std::move(nodes)}, {"edges", std::move(edges)}};
}

NavGraph readNavGraph(const std::filesystem::path& file) {
  return navGraphFromJson(common::readJsonFile(file), file.string());
}

void writeNavGraph(const std::filesystem::path& file, const NavGraph& graph) {
  common::writeJsonFile(file, navGraphToJson(graph));
}

}  // namespace vln::data
