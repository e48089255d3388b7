#include "waypoint/WaypointCommands.h"

#include <algorithm>
#include <cstdio>
#include <map>
#include <random>
#include <set>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "common/Check.h"
#include "common/Json.h"
#include "common/Random.h"
#include "common/ThreadPool.h"
#include "data/Episode.h"
#include "data/NavGraph.h"
#include "data/NodeTransfer.h"
#include "sim/Panorama.h"
#include "sim/Scene.h"
#include "waypoint/WaypointMetrics.h"

namespace vln::waypoint {

namespace {

constexpr const char* kCommand = "vlnce-data waypoint-metrics";

// What one house contributes.
struct HouseResult {
  std::string name;
  int nodes = 0;   ///< graph nodes
  int valid = 0;   ///< transferred onto the navmesh
  int scored = 0;  ///< valid nodes looked at (max_nodes)
  int kept = 0;    ///< with targets left in open space
  PredictorMetrics baseline;
  PredictorMetrics targets;  ///< the targets' own cells as predictions
};

HouseResult scoreHouse(const WaypointMetricsOptions& options,
                       const std::string& sceneId) {
  HouseResult house;
  const auto scene =
      sim::Scene::load(options.scenes_dir / sceneId, options.sim);
  house.name = scene->name();
  const data::NavGraph graph = data::readNavGraph(
      options.dataset / "connectivity" / (house.name + "_connectivity.json"));
  const std::vector<data::NodeTransferResult> transferred =
      data::transferGraph(graph, scene->navmesh(), data::TransferConfig{});
  house.nodes = graph.numNodes();
  std::vector<int> valid;
  for (int i = 0; i < graph.numNodes(); ++i)
    if (transferred[static_cast<size_t>(i)].valid) valid.push_back(i);
  house.valid = static_cast<int>(valid.size());
  // evenly spaced nodes when capped, so every part of the house counts
  std::vector<int> nodes = valid;
  if (options.max_nodes >= 0 &&
      static_cast<int>(valid.size()) > options.max_nodes) {
    nodes.clear();
    for (int k = 0; k < options.max_nodes; ++k)
      nodes.push_back(valid[static_cast<size_t>(k) * valid.size() /
                            static_cast<size_t>(options.max_nodes)]);
  }
  house.scored = static_cast<int>(nodes.size());

  sim::PanoramaConfig panoramaConfig = options.panorama;
  panoramaConfig.threads = 1;  // houses run in parallel instead
  sim::PanoramaRenderer renderer(*scene, panoramaConfig, options.sim.renderer);
  sim::Panorama panorama;
  for (int node : nodes) {
    // the agent arrives from anywhere: a heading per node from the seed
    std::mt19937_64 rng(common::episodeSeed(static_cast<uint64_t>(options.seed),
                                            graph.node(node).id));
    const float heading = common::uniformRange(rng, -kPi, kPi);
    const NodeTargets targets =
        nodeTargets(graph, transferred, node, heading, scene->navmesh(),
                    options.sim.agent, options.targets);
    if (!targets.kept) continue;
    ++house.kept;
    renderer.render(targets.agent, panorama);
    house.baseline.add(scoreCandidates(
        depthBaselineCandidates(panorama, panoramaConfig, options.baseline)
            .candidates,
        targets));
    std::vector<Candidate> own;
    for (const TargetWaypoint& t : targets.targets)
      own.push_back(candidateAt(t.heading_bin, t.distance_bin, 1.0f));
    house.targets.add(scoreCandidates(own, targets));
  }
  return house;
}

std::string row(const char* name, const PredictorMetrics& m) {
  char line[256];
  std::snprintf(line, sizeof(line),
                "%-34s %8.2f %8.2f %8.2f %7.1f%% %7.2f %7.2f %6lld\n", name,
                m.candidatesPerNode(), m.meanDelta(), m.meanAbsDelta(),
                100.0 * m.openShare(), m.meanChamfer(), m.meanHausdorff(),
                static_cast<long long>(m.empty));
  return line;
}

}  // namespace

int runWaypointMetricsCommand(const WaypointMetricsOptions& options,
                              std::ostream& out) {
  VLN_CHECK_ARG(options.max_nodes >= -1, kCommand,
                ": --max-nodes must be -1 (all) or >= 0, got ",
                options.max_nodes);
  VLN_CHECK_ARG(options.threads >= 1 && options.threads <= 64, kCommand,
                ": --threads must be in [1, 64], got ", options.threads);
  sim::checkPanoramaConfig(options.panorama, kCommand);

  // the split's houses, in file order of first appearance
  const std::filesystem::path episodesFile =
      options.dataset / options.split / (options.split + ".json.gz");
  const data::EpisodeDataset episodes = data::readEpisodes(episodesFile);
  std::vector<std::string> sceneIds;
  std::set<std::string> seen;
  for (const data::Episode& e : episodes.episodes)
    if (seen.insert(e.scene_id).second) sceneIds.push_back(e.scene_id);
  std::sort(sceneIds.begin(), sceneIds.end());
  VLN_CHECK_ARG(!sceneIds.empty(), kCommand, ": ", episodesFile.string(),
                " has no episodes");

  std::vector<HouseResult> houses(sceneIds.size());
  common::ThreadPool pool(
      std::min(options.threads, static_cast<int>(sceneIds.size())));
  pool.parallelFor(sceneIds.size(), [&](size_t i) {
    houses[i] = scoreHouse(options, sceneIds[i]);
  });

  // totals in house order (deterministic whatever the threads)
  HouseResult total;
  nlohmann::json perHouse = nlohmann::json::array();
  for (const HouseResult& h : houses) {
    total.nodes += h.nodes;
    total.valid += h.valid;
    total.scored += h.scored;
    total.kept += h.kept;
    total.baseline.merge(h.baseline);
    total.targets.merge(h.targets);
    perHouse.push_back({{"house", h.name},
                        {"nodes", h.nodes},
                        {"valid", h.valid},
                        {"scored", h.scored},
                        {"kept", h.kept},
                        {"baseline", h.baseline.toJson()}});
  }
  const nlohmann::json report = {{"split", options.split},
                                 {"houses", perHouse},
                                 {"nodes", total.nodes},
                                 {"valid", total.valid},
                                 {"scored", total.scored},
                                 {"kept", total.kept},
                                 {"baseline", total.baseline.toJson()},
                                 {"targets", total.targets.toJson()},
                                 {"seed", options.seed}};
  if (!options.out.empty()) common::writeJsonFile(options.out, report, 2);
  if (options.json) {
    out << report.dump(2) << "\n";
    return 0;
  }
  out << options.split << ": " << houses.size() << " houses, " << total.nodes
      << " nav-graph nodes, " << total.valid << " transferred, " << total.scored
      << " looked at, " << total.kept << " with targets in open space (mean "
      << total.targets.targetsPerNode() << " targets each)\n";
  out << "predictor                          cand/pano    delta  |delta|   "
         "%Open     d_C"
         "     d_H  empty\n";
  out << row("depth-only baseline", total.baseline);
  out << row("targets at their cells (floor)", total.targets);
  if (!options.out.empty()) out << "wrote " << options.out.string() << "\n";
  return 0;
}

}  // namespace vln::waypoint
