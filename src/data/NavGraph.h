#pragma once
// The R2R navigation graph of one scene: panorama viewpoints (nodes) joined
// by undirected, navigable edges. VLN uses it as the agent's action space;
// VLN-CE uses it only to compare continuous paths with nav-graph methods
// (paper Table 3 and its supplement).
//
// File layout (.json or .json.gz), positions in the Habitat world frame
// (+Y up, metres), i.e. the same points as R2R_VLNCE reference paths:
//
//   {"nodes": {"<viewpoint id>": [x, y, z], ...},
//    "edges": [["<id a>", "<id b>"], ...]}
//
// Edges are undirected; repeating an edge is allowed and ignored.

#include <filesystem>
#include <span>
#include <string>
#include <string_view>
#include <unordered_map>
#include <utility>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "common/Math.h"

namespace vln::data {

/// One viewpoint of the graph.
struct NavGraphNode {
  std::string id;                  ///< R2R viewpoint id
  Vec3f position = Vec3f::Zero();  ///< world frame, +Y up, metres
};

/// An undirected graph with Euclidean edge weights. Nodes are addressed by
/// dense indices 0..numNodes()-1 in insertion order.
class NavGraph {
 public:
  /// Adds a node and returns its index. Throws std::invalid_argument on a
  /// duplicate or empty id, or a non-finite position.
  int addNode(std::string id, const Vec3f& position);
  /// Adds the undirected edge a-b (by id). Throws std::invalid_argument for
  /// an unknown id or a self-loop; a repeated edge is ignored.
  void addEdge(std::string_view a, std::string_view b);

  /// Number of nodes.
  int numNodes() const { return static_cast<int>(nodes_.size()); }
  /// Number of distinct undirected edges.
  int numEdges() const { return numEdges_; }
  /// Node `index` (0 <= index < numNodes()).
  const NavGraphNode& node(int index) const;
  /// Index of the node called `id`, or -1 when there is none.
  int find(std::string_view id) const;
  /// Index of the node called `id`; throws std::invalid_argument naming the
  /// id when there is none.
  int indexOf(std::string_view id) const;
  /// Indices of the nodes adjacent to `index`, ascending.
  std::span<const int> neighbors(int index) const;
  /// True when an edge joins a and b.
  bool adjacent(int a, int b) const;
  /// Every undirected edge once, as (lower index, higher index), sorted.
  std::vector<std::pair<int, int>> edges() const;

  /// Straight-line 3-D distance between two nodes, metres (the weight of
  /// their edge when they are adjacent).
  double euclidean(int a, int b) const;
  /// Index of the node nearest to `position` (3-D Euclidean, ties to the
  /// lower index); -1 for an empty graph.
  int nearestNode(const Vec3f& position) const;
  /// Shortest-path distances (Dijkstra over Euclidean edge weights, metres)
  /// from `from` to every node, +infinity where unreachable.
  std::vector<double> distancesFrom(int from) const;
  /// Shortest-path distance between two nodes, metres; +infinity when they
  /// are not connected.
  double distance(int a, int b) const;
  /// Node indices of a shortest path from `from` to `to`, both included;
  /// empty when they are not connected.
  std::vector<int> shortestPath(int from, int to) const;

 private:
  void dijkstra(int from, std::vector<double>& dist,
                std::vector<int>& previous) const;

  std::vector<NavGraphNode> nodes_;
  std::vector<std::vector<int>> adjacency_;  // sorted per node
  std::unordered_map<std::string, int> index_;
  int numEdges_ = 0;
};

/// Builds a graph from the JSON layout above; `source` names the file in
/// errors, which also name the field (e.g. "nodes.abc[1]").
NavGraph navGraphFromJson(const nlohmann::json& json, std::string_view source);
/// The JSON layout above (node keys sorted by id, edges by id pair).
nlohmann::json navGraphToJson(const NavGraph& graph);
/// Reads a graph file (.json or .json.gz); errors name the file and field.
NavGraph readNavGraph(const std::filesystem::path& file);
/// Atomically writes `graph` to `file` (gzip when it ends in .gz).
void writeNavGraph(const std::filesystem::path& file, const NavGraph& graph);

}  // namespace vln::data
