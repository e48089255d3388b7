#include "eval/NavGraphEval.h"

#include <array>
#include <cmath>
#include <limits>
#include <utility>

#include "common/Check.h"
#include "common/Json.h"
#include "data/NodeTransfer.h"
#include "rollout/Metrics.h"

namespace vln::eval {
namespace {

constexpr std::array<std::pair<const char*, double GraphEpisodeMetrics::*>, 8>
    kGraphKeys{
        {{"path_length", &GraphEpisodeMetrics::path_length},
         {"distance_to_goal", &GraphEpisodeMetrics::distance_to_goal},
         {"oracle_error", &GraphEpisodeMetrics::oracle_error},
         {"oracle_success", &GraphEpisodeMetrics::oracle_success},
         {"success", &GraphEpisodeMetrics::success},
         {"spl", &GraphEpisodeMetrics::spl},
         {"shortest_path_length", &GraphEpisodeMetrics::shortest_path_length},
         {"trajectory_steps", &GraphEpisodeMetrics::trajectory_steps}}};

}  // namespace

// ---------------------------------------------------------------------------
// conversion
// ---------------------------------------------------------------------------

EpisodeNodes episodeNodes(const data::NavGraph& graph,
                          std::span<const Vec3f> referencePath,
                          std::string_view episodeId, double tolerance) {
  VLN_CHECK_ARG(!referencePath.empty(), "episodeNodes(): episode '", episodeId,
                "' has an empty reference_path");
  VLN_CHECK_ARG(graph.numNodes() > 0, "episodeNodes(): episode '", episodeId,
                "': the nav-graph has no nodes");
  auto nearest = [&](const Vec3f& p, const char* which) {
    const int node = graph.nearestNode(p);
    const double gap = (graph.node(node).position - p).cast<double>().norm();
    VLN_CHECK_ARG(gap <= tolerance, "episodeNodes(): episode '", episodeId,
                  "': the ", which, " of reference_path is ", gap,
                  " m from the nearest nav-graph node '", graph.node(node).id,
                  "' (tolerance ", tolerance, " m); wrong scene graph?");
    return node;
  };
  return {nearest(referencePath.front(), "start"),
          nearest(referencePath.back(), "end")};
}

std::vector<int> snapPathToGraph(const data::NavGraph& graph, int startNode,
                                 std::span<const Vec3f> positions) {
  VLN_ASSERT(startNode >= 0 && startNode < graph.numNodes());
  std::vector<int> path{startNode};
  int current = startNode;
  // p_0 is aligned with the start node; p_1..p_T each move at most one hop
  for (size_t t = 1; t < positions.size(); ++t) {
    const Vec3d p = positions[t].cast<double>();
    int best = current;
    double bestDistance =
        (graph.node(current).position.cast<double>() - p).norm();
    for (int n : graph.neighbors(current)) {  // ascending indices
      const double d = (graph.node(n).position.cast<double>() - p).norm();
      if (d < bestDistance) {
        bestDistance = d;
        best = n;
      }
    }
    if (best != current) {
      current = best;
      path.push_back(current);
    }
  }
  return path;
}

// ---------------------------------------------------------------------------
// scoring (R2R tasks/R2R/eval.py)
// ---------------------------------------------------------------------------

GraphEpisodeMetrics scoreGraphPath(const data::NavGraph& graph,
                                   std::span<const int> path, int goalNode,
                                   double errorMargin) {
  VLN_CHECK_ARG(!path.empty(), "scoreGraphPath(): empty trajectory");
  VLN_ASSERT(goalNode >= 0 && goalNode < graph.numNodes());
  // eval.py looks every distance up in all-pairs shortest paths; the graph is
  // undirected, so one search from the goal serves NE, the oracle and d
  const std::vector<double> toGoal = graph.distancesFrom(goalNode);
  for (int node : path) {
    VLN_ASSERT(node >= 0 && node < graph.numNodes());
    VLN_CHECK_ARG(std::isfinite(toGoal[node]), "scoreGraphPath(): node '",
                  graph.node(node).id, "' is not connected to the goal '",
                  graph.node(goalNode).id, "'");
  }

  GraphEpisodeMetrics m;
  m.distance_to_goal = toGoal[path.back()];
  // _get_nearest(): the first node with the smallest distance to the goal
  m.oracle_error = toGoal[path.front()];
  for (int node : path) m.oracle_error = std::min(m.oracle_error, toGoal[node]);
  for (size_t i = 1; i < path.size(); ++i)
    if (path[i] != path[i - 1])
      m.path_length += graph.distance(path[i - 1], path[i]);
  m.shortest_path_length = toGoal[path.front()];
  m.trajectory_steps = static_cast<double>(path.size()) - 1.0;

  m.success = m.distance_to_goal < errorMargin ? 1.0 : 0.0;
  m.oracle_success = m.oracle_error < errorMargin ? 1.0 : 0.0;
  // eval.py: sp / max(length, sp) for successes (with sp = 0 the start is
  // the goal and the trajectory cannot be shorter, so it scores 1)
  if (m.success > 0.0) {
    const double denominator = std::max(m.path_length, m.shortest_path_length);
    m.spl = denominator > 0.0 ? m.shortest_path_length / denominator : 1.0;
  }
  return m;
}

GraphEpisodeMetrics scoreContinuousPath(const data::NavGraph& graph,
                                        std::span<const Vec3f> positions,
                                        std::span<const Vec3f> referencePath,
                                        std::string_view episodeId,
                                        double errorMargin) {
  VLN_CHECK_ARG(!positions.empty(), "scoreContinuousPath(): episode '",
                episodeId, "' has no agent positions");
  const EpisodeNodes nodes = episodeNodes(graph, referencePath, episodeId);
  const std::vector<int> path = snapPathToGraph(graph, nodes.start, positions);
  return scoreGraphPath(graph, path, nodes.goal, errorMargin);
}

// ---------------------------------------------------------------------------
// aggregation and files
// ---------------------------------------------------------------------------

GraphSplitStats aggregateGraph(std::span<const GraphEpisodeMetrics> episodes) {
  return rollout::averageMetrics<GraphSplitStats>(episodes, kGraphKeys,
                                                  "aggregateGraph()");
}

std::string graphStatsFileName(int checkpoint, std::string_view split) {
  return strCat("navgraph_stats_ckpt_", checkpoint, "_", split, ".json");
}

nlohmann::json graphStatsToJson(const GraphSplitStats& stats) {
  nlohmann::json out = nlohmann::json::object();
  for (const auto& [key, member] : kGraphKeys) out[key] = stats.mean.*member;
  out["num_episodes"] = stats.num_episodes;
  return out;
}

GraphSplitStats graphStatsFromJson(const nlohmann::json& json,
                                   std::string_view source) {
  const std::string where(source);
  GraphSplitStats stats;
  for (const auto& [key, member] : kGraphKeys)
    stats.mean.*member = common::requireField<double>(json, key, where);
  stats.num_episodes = common::requireField<int>(json, "num_episodes", where);
  VLN_CHECK_ARG(stats.num_episodes > 0, where,
                ": field 'num_episodes' must be positive, got ",
                stats.num_episodes);
  return stats;
}

std::filesystem::path writeGraphStatsFile(const std::filesystem::path& dir,
                                          int checkpoint,
                                          std::string_view split,
                                          const GraphSplitStats& stats) {
  const auto file = dir / graphStatsFileName(checkpoint, split);
  common::writeJsonFile(file, graphStatsToJson(stats), /*indent=*/4);
  return file;
}

GraphSplitStats readGraphStatsFile(const std::filesystem::path& file) {
  return graphStatsFromJson(common::readJsonFile(file), file.string());
}

data::NavGraph floorNavGraph(const data::NavGraph& graph,
                             const sim::NavMesh& navmesh) {
  const std::vector<data::NodeTransferResult> transferred =
      data::transferGraph(graph, navmesh, data::TransferConfig{});
  data::NavGraph floor;
  for (int i = 0; i < graph.numNodes(); ++i) {
    const auto& t = transferred[static_cast<size_t>(i)];
    floor.addNode(graph.node(i).id, t.valid ? t.waypoint : graph.node(i).position);
  }
  for (const auto& [a, b] : graph.edges())
    floor.addEdge(graph.node(a).id, graph.node(b).id);
  return floor;
}

GraphEpisodeMetrics scoreOnNavGraph(const data::NavGraph& graph,
                                    const data::NavGraph& floorGraph,
                                    std::span<const Vec3f> positions,
                                    std::span<const Vec3f> referencePath,
                                    std::string_view episodeId) {
  VLN_CHECK_ARG(graph.numNodes() == floorGraph.numNodes(),
                "scoreOnNavGraph(): episode ", episodeId, ": the floor graph has ",
                floorGraph.numNodes(), " nodes, the graph ", graph.numNodes());
  // matching on the floor, where the agent and the reference path are
  const EpisodeNodes nodes = episodeNodes(floorGraph, referencePath, episodeId);
  const std::vector<int> path = snapPathToGraph(floorGraph, nodes.start, positions);
  // scoring on the viewpoints themselves (node indices are shared)
  return scoreGraphPath(graph, path, nodes.goal);
}

}  // namespace vln::eval
