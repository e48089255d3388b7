#include "world/WorldCommands.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <random>

#include "common/Check.h"
#include "common/Config.h"
#include "common/Json.h"
#include "common/Progress.h"
#include "common/Random.h"
#include "data/NavGraph.h"
#include "data/NodeTransfer.h"
#include "sim/Scene.h"
#include "sim/SimConfig.h"
#include "world/RxrWorldGenerator.h"
#include "world/TrajectorySampler.h"
#include "world/WorldGenerator.h"

namespace vln::world {

namespace {

WorldConfig loadConfig(const std::filesystem::path& file,
                       const std::vector<std::string>& overrides) {
  if (!file.empty())
    return common::loadConfigFile<WorldConfig>(file, overrides);
  return common::loadConfigText<WorldConfig>("{}", "<defaults>", overrides);
}

}  // namespace

WorldConfig loadWorldConfig(const GenerateCommandOptions& options) {
  WorldConfig config = loadConfig(options.config, options.overrides);
  if (options.houses) config.houses = *options.houses;
  if (options.seed) config.seed = *options.seed;
  WorldConfig checked = config;
  common::checkConfig([&](common::ConfigVisitor& v) { checked.visit(v); },
                      options.config.empty() ? std::string("--houses/--seed")
                                             : options.config.string());
  config.validate();
  return config;
}

bool isRxrWorldConfigFile(const std::filesystem::path& file) {
  std::ifstream in(file);
  VLN_CHECK_IO(in.good(), "isRxrWorldConfigFile(): cannot read '",
               file.string(), "'");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("world:", 0) == 0) return true;
  return false;
}

RxrWorldConfig loadRxrWorldConfig(const GenerateCommandOptions& options) {
  RxrWorldConfig config =
      common::loadConfigFile<RxrWorldConfig>(options.config, options.overrides);
  if (options.houses) config.world.houses = *options.houses;
  if (options.seed) config.seed = config.world.seed = *options.seed;
  RxrWorldConfig checked = config;
  common::checkConfig([&](common::ConfigVisitor& v) { checked.visit(v); },
                      options.config.string());
  config.validate();
  return config;
}

int runGenerateCommand(const GenerateCommandOptions& options,
                       std::ostream& out) {
  VLN_CHECK_ARG(options.threads >= 1,
                "vlnce-data generate: --threads must be >= 1, got ",
                options.threads);
  if (!options.config.empty() && isRxrWorldConfigFile(options.config)) {
    const RxrWorldConfig config = loadRxrWorldConfig(options);
    const common::Stopwatch clock;
    WorldOutput output{options.out, options.scenes_dir, options.threads};
    generateRxrWorld(config, output, &out);
    out << "wrote " << options.out.string() << " and the RxR agent's navmeshes "
        << "beside the scenes under "
        << (options.scenes_dir / config.world.scene_prefix).string() << " in "
        << std::lround(clock.seconds()) << " s\n";
    return 0;
  }
  const WorldConfig config = loadWorldConfig(options);
  const common::Stopwatch clock;
  WorldOutput output{options.out, options.scenes_dir, options.threads};
  generateWorld(config, output, &out);
  out << "wrote " << options.out.string() << " and scenes under "
      << (options.scenes_dir / config.scene_prefix).string() << " in "
      << std::lround(clock.seconds()) << " s\n";
  return 0;
}

int runTransferCommand(const TransferCommandOptions& options,
                       std::ostream& out) {
  VLN_CHECK_ARG(options.trajectories >= 0,
                "vlnce-data transfer: --trajectories must be >= 0, got ",
                options.trajectories);
  VLN_CHECK_ARG(options.up_axis == "y" || options.up_axis == "z",
                "vlnce-data transfer: --up-axis must be y or z, got '",
                options.up_axis, "'");
  const WorldConfig config = loadConfig(options.config, options.overrides);

  // the scene with its navmesh (cached beside it, as the simulator does)
  const data::NavGraph graph = data::readNavGraph(options.graph);
  sim::SimConfig sim;
  sim.navmesh = config.navmesh;
  sim.mesh.up_axis = options.up_axis == "z" ? sim::UpAxis::kZ : sim::UpAxis::kY;
  const auto scene = sim::Scene::load(options.scene, sim);
  const sim::NavMesh& navmesh = scene->navmesh();

  // nodes, then sampled trajectories
  data::TransferStats stats;
  const std::vector<data::NodeTransferResult> transferred =
      data::transferGraph(graph, navmesh, config.transfer);
  stats.addNodes(transferred, config.transfer);
  const TrajectorySampler sampler(graph, config.trajectories);
  const auto order = sampler.shuffledOrder(static_cast<uint64_t>(options.seed));
  std::mt19937_64 rng(common::deriveSeed(static_cast<uint64_t>(options.seed), 1));
  const size_t count =
      std::min(order.size(), static_cast<size_t>(options.trajectories));
  for (size_t i = 0; i < count; ++i) {
    const float heading = common::uniformRange(rng, -kPi, kPi);
    stats.addTrajectory(data::checkNavigability(
        navmesh, config.agent, config.transfer, transferred,
        sampler.candidate(order[i]), heading));
  }

  // report
  if (options.json) {
    out << stats.toJson().dump(2) << "\n";
  } else {
    out << options.graph.string() << " on " << options.scene.string() << ": "
        << graph.numNodes() << " nodes, " << graph.numEdges() << " edges, "
        << sampler.size() << " R2R-like trajectories, " << count << " checked\n"
        << stats.report();
  }

  if (!options.out.empty()) {
    nlohmann::json result = {{"nodes", nlohmann::json::object()},
                             {"edges", nlohmann::json::array()},
                             {"rejected", nlohmann::json::array()},
                             {"displacement", nlohmann::json::object()},
                             {"stats", stats.toJson()}};
    for (int i = 0; i < graph.numNodes(); ++i) {
      const auto& node = graph.node(i);
      const data::NodeTransferResult& t = transferred[static_cast<size_t>(i)];
      if (!t.valid) {
        result["rejected"].push_back(node.id);
        continue;
      }
      result["nodes"][node.id] = {t.waypoint.x(), t.waypoint.y(),
                                  t.waypoint.z()};
      result["displacement"][node.id] = t.displacement;
    }
    for (const auto& [a, b] : graph.edges())
      if (transferred[static_cast<size_t>(a)].valid &&
          transferred[static_cast<size_t>(b)].valid)
        result["edges"].push_back({graph.node(a).id, graph.node(b).id});
    common::writeJsonFile(options.out, result, 2);
    if (!options.json) out << "wrote " << options.out.string() << "\n";
  }
  return 0;
}

}  // namespace vln::world
