#pragma once
// Nav-graph comparison (paper Sec. 5.3, Table 3 and the supplement's
// "Converting VLN-CE Paths to Nav-Graph-based VLN"): a continuous agent path
// is snapped onto the scene's R2R nav-graph and scored with VLN's metrics as
// R2R's tasks/R2R/eval.py computes them. All distances are shortest paths
// through the graph with Euclidean edge weights (metres), the positions are
// in the Habitat world frame (+Y up).

#include <filesystem>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "common/Math.h"
#include "data/NavGraph.h"
#include "sim/NavMesh.h"

namespace vln::eval {

/// R2R eval.py's error_margin: success when the final viewpoint is within
/// 3 m (shortest path through the graph) of the goal viewpoint.
inline constexpr double kGraphErrorMargin = 3.0;

/// Start and goal viewpoints of an episode.
struct EpisodeNodes {
  int start = -1;  ///< node index of the R2R path's first viewpoint
  int goal = -1;   ///< node index of its last viewpoint
};

/// Nodes nearest (3-D Euclidean) to the first and last reference-path points
/// (R2R_VLNCE reference paths are the R2R viewpoints moved onto the floor).
/// Throws std::invalid_argument naming `episodeId` when the path is empty,
/// the graph is empty, or a nearest node is farther than `tolerance` metres
/// (the graph does not belong to the episode's scene).
EpisodeNodes episodeNodes(const data::NavGraph& graph,
                          std::span<const Vec3f> referencePath,
                          std::string_view episodeId, double tolerance = 1.0);

/// The supplement's conversion: the current node starts at `startNode`
/// (aligned with positions[0]); for every later position the current node
/// becomes the node nearest to it (3-D Euclidean) among the current node
/// and its neighbours, ties kept on the current node, then the lowest
/// index. Returns the visited nodes with consecutive repeats removed
/// (a VLN trajectory lists a viewpoint once per visit), starting with
/// `startNode`.
std::vector<int> snapPathToGraph(const data::NavGraph& graph, int startNode,
                                 std::span<const Vec3f> positions);

/// VLN metrics of one graph trajectory, named like VLN-CE's so that the
/// tables treat both alike.
struct GraphEpisodeMetrics {
  double path_length =
      0.0;  ///< TL: sum of distances between consecutive nodes (m)
  double distance_to_goal = 0.0;  ///< NE: final node to goal node (m)
  double oracle_error =
      0.0;  ///< min over visited nodes of the distance to goal (m)
  double oracle_success = 0.0;  ///< OS: oracle_error < margin
  double success = 0.0;         ///< SR: NE < margin
  double spl = 0.0;  ///< success * d / max(TL, d), d = start-to-goal (m)
  double shortest_path_length = 0.0;  ///< d (m)
  double trajectory_steps = 0.0;      ///< path.size() - 1
  bool operator==(const GraphEpisodeMetrics&) const = default;
};

/// Scores `path` (node indices, path[0] must be the start node) against
/// `goalNode` exactly like R2R eval.py's _score_item() and score(). Throws
/// std::invalid_argument when the path is empty or leaves the graph's
/// connected component of the goal.
GraphEpisodeMetrics scoreGraphPath(const data::NavGraph& graph,
                                   std::span<const int> path, int goalNode,
                                   double errorMargin = kGraphErrorMargin);

/// Convenience: episodeNodes(), snapPathToGraph() and scoreGraphPath() for
/// one continuous episode.
GraphEpisodeMetrics scoreContinuousPath(const data::NavGraph& graph,
                                        std::span<const Vec3f> positions,
                                        std::span<const Vec3f> referencePath,
                                        std::string_view episodeId,
                                        double errorMargin = kGraphErrorMargin);

/// Means of GraphEpisodeMetrics over a split.
struct GraphSplitStats {
  GraphEpisodeMetrics mean;
  int num_episodes = 0;
  bool operator==(const GraphSplitStats&) const = default;
};

/// Means over `episodes`; throws std::invalid_argument when empty.
GraphSplitStats aggregateGraph(std::span<const GraphEpisodeMetrics> episodes);

/// "navgraph_stats_ckpt_<checkpoint>_<split>.json".
std::string graphStatsFileName(int checkpoint, std::string_view split);
/// {"path_length", "distance_to_goal", "oracle_error", "oracle_success",
/// "success", "spl", "shortest_path_length", "trajectory_steps",
/// "num_episodes"}.
nlohmann::json graphStatsToJson(const GraphSplitStats& stats);
/// Inverse of graphStatsToJson(); errors name `source` and the field.
GraphSplitStats graphStatsFromJson(const nlohmann::json& json,
                                   std::string_view source);
/// Atomically writes `dir`/graphStatsFileName(); returns the path.
std::filesystem::path writeGraphStatsFile(const std::filesystem::path& dir,
                                          int checkpoint,
                                          std::string_view split,
                                          const GraphSplitStats& stats);
/// Reads a nav-graph stats file.
GraphSplitStats readGraphStatsFile(const std::filesystem::path& file);

/// A copy of `graph` (same ids, order and edges) whose nodes are moved to
/// their Section 3.2 waypoints on `navmesh` (data::transferGraph() with the
/// paper's TransferConfig); nodes that do not transfer keep their position.
/// Connectivity files hold R2R viewpoints at camera height (1.2-1.6 m above
/// the floor), while agent positions and R2R_VLNCE reference paths are on
/// the floor, so the agent's path is matched against this copy.
data::NavGraph floorNavGraph(const data::NavGraph& graph,
                             const sim::NavMesh& navmesh);

/// The supplement's conversion of one continuous episode: start and goal
/// nodes from the reference path and the agent's path snapped node by node,
/// both on `floorGraph` (floorNavGraph() of `graph`), then scored with R2R's
/// eval.py on `graph` itself (the viewpoints' own geometry, as the VLN
/// leaderboard scores them).
GraphEpisodeMetrics scoreOnNavGraph(const data::NavGraph& graph,
                                    const data::NavGraph& floorGraph,
                                    std::span<const Vec3f> positions,
                                    std::span<const Vec3f> referencePath,
                                    std::string_view episodeId);

}  // namespace vln::eval
