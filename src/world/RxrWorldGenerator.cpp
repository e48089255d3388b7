#include "world/RxrWorldGenerator.h"

#include <unistd.h>
#include <algorithm>
#include <cmath>
#include <optional>
#include <set>
#include <stdexcept>

#include "common/Check.h"
#include "common/Config.h"
#include "common/FileIo.h"
#include "common/Json.h"
#include "common/Random.h"
#include "data/Episode.h"
#include "data/GroundTruth.h"
#include "data/NodeTransfer.h"
#include "data/RxrEpisodes.h"
#include "sim/MeshIo.h"
#include "sim/Scene.h"
#include "world/InstructionGenerator.h"
#include "world/RxrAnnotations.h"
#include "world/RxrFollower.h"
#include "world/RxrPathSampler.h"
#include "world/TrajectorySampler.h"

namespace vln::world {

namespace {

namespace fs = std::filesystem;

// Stream labels for common::deriveSeed() under the RxR seed.
enum Stream : uint64_t {
  kRxrStream = 0x727872ull,  // "rxr"
  kWalkStream = 1,
  kHeadingStream = 2,
  kInstructionStream = 3,
  kAnnotatorStream = 4,
};

constexpr const char* kTrain = "train";
constexpr const char* kValSeen = "val_seen";
constexpr const char* kValUnseen = "val_unseen";
constexpr const char* kTestChallenge = "test_challenge";
constexpr const char* kGuide = "guide";
constexpr const char* kFollower = "follower";

// ---------------------------------------------------------------------------
// per house
// ---------------------------------------------------------------------------

// One annotation of a walk.
struct Annotation {
  std::string role;  // guide or follower
  std::string language;
  std::string text;
  std::string annotator;
  std::vector<data::TimedWord> timed;
  double duration = 0.0;  // seconds
};

// One kept walk with everything its episodes need.
struct Walk {
  std::string split;
  std::vector<Vec3f> waypoints;  // transferred reference path
  float start_heading = 0.0f;
  float geodesic = 0.0f;
  double graph_length = 0.0;  // along nav-graph edges, metres
  int rooms = 0;              // rooms the ground truth passes through
  int node_rooms = 0;         // rooms of its waypoints
  data::GroundTruthPath ground_truth;
  std::vector<Annotation> annotations;
};

struct HouseResult {
  std::string name;
  std::string scene_id;
  std::string role;
  data::NavGraph graph;
  data::TransferStats transfer;
  int walks_drawn = 0;
  // the R2R sampler's shortest-path candidates on the same graph, for the
  // length comparison
  int r2r_candidates = 0;
  double r2r_candidate_length = 0.0;
  double r2r_candidate_rooms = 0.0;  // rooms of the valid waypoints
  std::vector<Walk> walks;           // in acceptance order
};

std::vector<std::pair<std::string, int>> quotas(const RxrWorldConfig& config,
                                                const std::string& role) {
  const RxrSplitConfig& s = config.splits;
  if (role == "train")
    return {{kTrain, s.train_per_house}, {kValSeen, s.val_seen_per_house}};
  if (role == "val_unseen") return {{kValUnseen, s.val_unseen_per_house}};
  if (role == "test") return {{kTestChallenge, s.test_challenge_per_house}};
  return {};
}

uint64_t rxrHouseSeed(const RxrWorldConfig& config, int index) {
  return common::deriveSeed(
      common::deriveSeed(static_cast<uint64_t>(config.seed), kRxrStream),
      static_cast<uint64_t>(index));
}

// The annotations of one walk: guides first, then followers.
std::vector<Annotation> annotate(const RxrWorldConfig& config,
                                 const InstructionGenerator& generator,
                                 const Walk& walk, uint64_t seed) {
  const RxrInstructionConfig& c = config.instructions;
  const int count = c.guide_per_trajectory + c.follower_per_trajectory;
  const std::vector<GeneratedInstruction> generated = generator.generate(
      walk.waypoints, walk.start_heading, InstructionStyle::kHuman, count,
      common::deriveSeed(seed, kInstructionStream));
  std::mt19937_64 rng(common::deriveSeed(seed, kAnnotatorStream));
  std::vector<Annotation> result;
  for (int i = 0; i < count; ++i) {
    Annotation a;
    const bool guide = i < c.guide_per_trajectory;
    a.role = guide ? kGuide : kFollower;
    GeneratedInstruction g = generated[static_cast<size_t>(i)];
    const bool indian = common::bernoulli(rng, c.en_in_fraction);
    a.language = indian ? "en-IN" : "en-US";
    if (indian) {
      g.text = toIndianEnglish(g.text);
      for (LandmarkMention& m : g.landmarks)
        m.phrase = toIndianEnglish(m.phrase);
    }
    a.annotator = std::to_string(common::uniformIndex(rng, c.annotators));
    const WalkTimes times = walkTimes(
        walk.waypoints, guide ? c.guide_speed : c.follower_speed, c.node_pause);
    a.timed = timeInstruction(g, times);
    a.duration = times.duration();
    a.text = std::move(g.text);
    result.push_back(std::move(a));
  }
  return result;
}

HouseResult processHouse(const RxrWorldConfig& config,
                         const WorldOutput& output, int index,
                         const std::string& role) {
  HouseResult result;
  result.role = role;

  // the world's house; its scene is written only when absent, so that a
  // default world's navmesh cache beside it stays newer than the scene
  WorldHouse captured = buildWorldHouse(config.world, index);
  result.name = captured.name;
  result.scene_id = captured.scene_id;
  const fs::path sceneFile = output.scenes_dir / result.scene_id;
  if (!fs::exists(sceneFile))
    sim::saveScene(sceneFile, captured.house.mesh, captured.house.semantics);

  // the RxR agent's navmesh, where the simulator looks for it
  const auto scene =
      sim::Scene::fromMesh(result.name, std::move(captured.house.mesh),
                           std::move(captured.house.semantics), config.navmesh);
  const sim::NavMesh& navmesh = scene->navmesh();
  navmesh.save(sim::navMeshVariantFile(sceneFile, config.navmesh));
  fs::path cacheFile = sceneFile;
  cacheFile += ".navmesh";
  if (!fs::exists(cacheFile)) navmesh.save(cacheFile);

  // nodes on that navmesh; the R2R candidates for comparison
  const data::NavGraph& graph = captured.built.graph;
  const std::vector<data::NodeTransferResult> transferred =
      data::transferGraph(graph, navmesh, config.world.transfer);
  result.transfer.addNodes(transferred, config.world.transfer);
  const TrajectorySampler r2r(graph, config.world.trajectories);
  result.r2r_candidates = r2r.size();
  for (const GraphPath& path : r2r.candidates()) {
    result.r2r_candidate_length += pathLength(graph, path);
    std::vector<Vec3f> points;
    for (const int node : path)
      if (transferred[static_cast<size_t>(node)].valid)
        points.push_back(transferred[static_cast<size_t>(node)].waypoint);
    result.r2r_candidate_rooms += roomsVisited(scene->semantics(), points);
  }

  // walks fill the splits of this house, each taking the next navigable
  // walk while it is the least filled relative to its quota
  auto splits = quotas(config, role);
  std::vector<int> filled(splits.size(), 0);
  int wanted = 0;
  for (const auto& [name, quota] : splits) wanted += quota;
  const int attempts = wanted * config.trajectories.attempts_per_trajectory;
  const uint64_t seed = rxrHouseSeed(config, index);
  const InstructionGenerator generator(scene->semantics(),
                                       config.world.instructions);
  std::set<GraphPath> seen;
  for (int k = 0; k < attempts && wanted > 0; ++k) {
    const uint64_t walkSeed = common::deriveSeed(
        common::deriveSeed(seed, kWalkStream), static_cast<uint64_t>(k));
    ++result.walks_drawn;
    std::optional<GraphPath> path =
        sampleRxrWalk(graph, config.trajectories, walkSeed);
    if (!path || !seen.insert(*path).second) continue;
    std::mt19937_64 headingRng(common::deriveSeed(walkSeed, kHeadingStream));
    const float heading = common::uniformRange(headingRng, -kPi, kPi);
    data::NavigabilityResult checked;
    std::vector<Vec3f> waypoints;
    for (size_t i = 0; i < path->size(); ++i) {
      const data::NodeTransferResult& t =
          transferred[static_cast<size_t>((*path)[i])];
      if (!t.valid) {
        checked.failure = data::NavigabilityFailure::kInvalidNode;
        checked.failed_index = static_cast<int>(i);
        break;
      }
      waypoints.push_back(t.waypoint);
    }
    if (checked.failure == data::NavigabilityFailure::kNone)
      checked = followRxrWalk(navmesh, config.agent, config.world.transfer,
                              waypoints, heading);
    result.transfer.addTrajectory(checked);
    if (!checked.navigable()) continue;

    size_t pick = splits.size();
    for (size_t s = 0; s < splits.size(); ++s) {
      if (filled[s] >= splits[s].second) continue;
      if (pick == splits.size() ||
          static_cast<int64_t>(filled[s]) * splits[pick].second <
              static_cast<int64_t>(filled[pick]) * splits[s].second)
        pick = s;
    }
    VLN_ASSERT(pick < splits.size());
    ++filled[pick];
    --wanted;

    Walk walk;
    walk.split = splits[pick].first;
    walk.waypoints = std::move(waypoints);
    walk.start_heading = heading;
    walk.geodesic = checked.geodesic_distance;
    walk.graph_length = pathLength(graph, *path);
    walk.ground_truth = std::move(checked.ground_truth);
    walk.rooms = roomsVisited(scene->semantics(), walk.ground_truth.locations);
    walk.node_rooms = roomsVisited(scene->semantics(), walk.waypoints);
    walk.annotations = annotate(config, generator, walk, walkSeed);
    result.walks.push_back(std::move(walk));
  }
  result.graph = graph;
  return result;
}

double mean(double sum, int64_t count) {
  return count > 0 ? sum / static_cast<double>(count) : 0.0;
}

}  // namespace

// ===========================================================================
// public API
// ===========================================================================

const std::vector<std::string>& rxrSplitNames() {
  static const std::vector<std::string> kNames = {kTrain, kValSeen, kValUnseen,
                                                  kTestChallenge};
  return kNames;
}

RxrWorldSummary generateRxrWorld(const RxrWorldConfig& config,
                                 const WorldOutput& output, std::ostream* log) {
  RxrWorldConfig checked = config;  // visit() is non-const
  common::checkConfig([&](common::ConfigVisitor& v) { checked.visit(v); },
                      "generateRxrWorld()");
  config.validate();
  VLN_CHECK_ARG(output.threads >= 1,
                "generateRxrWorld(): threads must be >= 1, got ",
                output.threads);
  VLN_CHECK_ARG(!output.out.empty(),
                "generateRxrWorld(): the output directory is empty");
  // the world's houses and roles (its extra train houses are not used)
  const std::vector<std::string> roles = worldHouseRoles(config.world);
  const int n = config.world.houses;

  // houses on a pool of threads; results land in house order
  std::vector<std::optional<HouseResult>> houses(static_cast<size_t>(n));
  forEachWorldHouse(config.world, n, output.threads, "generate-rxr",
                    "generateRxrWorld()", [&](int i) {
                      houses[static_cast<size_t>(i)] = processHouse(
                          config, output, i, roles[static_cast<size_t>(i)]);
                    });

  // episodes per split and role, in house order; test_challenge's goals and
  // ground truth only in the hidden copy
  using RoleFiles = std::map<std::string, data::EpisodeDataset>;
  using RoleTruth = std::map<std::string, data::GroundTruth>;
  std::map<std::string, RoleFiles> datasets, hidden;
  std::map<std::string, RoleTruth> truths;
  struct Sums {
    int walks = 0;
    double length = 0, geodesic = 0, nodes = 0, rooms = 0, actions = 0;
    int64_t instructions = 0;
    double words = 0, duration = 0;
    std::map<std::string, int> languages;
  };
  std::map<std::string, Sums> sums;
  int64_t instructionId = 0;
  int trajectoryId = 0;
  for (const std::string& split : rxrSplitNames()) {
    int episodeId = 0;
    Sums& sum = sums[split];
    for (const auto& house : houses) {
      for (const Walk& w : house->walks) {
        if (w.split != split) continue;
        ++trajectoryId;
        ++sum.walks;
        sum.length += w.graph_length;
        sum.geodesic += w.geodesic;
        sum.nodes += static_cast<double>(w.waypoints.size());
        sum.rooms += w.rooms;
        sum.actions += static_cast<double>(w.ground_truth.actions.size());
        for (const Annotation& a : w.annotations) {
          data::Episode e;
          e.episode_id = ++episodeId;
          e.trajectory_id = trajectoryId;
          e.scene_id = house->scene_id;
          e.start_position = w.waypoints.front();
          e.start_rotation = headingToQuaternion(w.start_heading);
          e.instruction.instruction_text = a.text;
          e.instruction.instruction_id = ++instructionId;
          e.instruction.language = a.language;
          e.instruction.annotator_id = a.annotator;
          // the follower walked the guide's path exactly
          e.instruction.edit_distance = 0.0;
          e.instruction.timed_instruction = a.timed;
          ++sum.instructions;
          sum.words += static_cast<double>(a.timed.size());
          sum.duration += a.duration;
          ++sum.languages[a.language];
          data::Episode withGoals = e;
          withGoals.geodesic_distance = w.geodesic;
          withGoals.goals = {
              data::Goal{w.waypoints.back(), data::kDefaultGoalRadius}};
          withGoals.reference_path = w.waypoints;
          if (split == kTestChallenge) {
            hidden[split][a.role].episodes.push_back(std::move(withGoals));
            truths[split][a.role][e.episode_id] = w.ground_truth;
            datasets[split][a.role].episodes.push_back(std::move(e));
          } else {
            truths[split][a.role][e.episode_id] = w.ground_truth;
            datasets[split][a.role].episodes.push_back(std::move(withGoals));
          }
        }
      }
    }
  }
  for (const std::string& split : rxrSplitNames()) {
    int wanted = 0;
    for (const std::string& role : roles)
      for (const auto& [name, quota] : quotas(config, role))
        if (name == split) wanted += quota;
    VLN_CHECK_IO(wanted == 0 || sums[split].walks > 0,
                 "generateRxrWorld(): split '", split,
                 "' got no navigable walk; the world is too small for its "
                 "quotas (houses ",
                 n, ")");
  }

  // statistics
  RxrWorldSummary summary;
  data::TransferStats transfer;
  int64_t r2rCandidates = 0, walksDrawn = 0;
  double r2rLength = 0.0, r2rRooms = 0.0, nodeRooms = 0.0;
  nlohmann::json perHouse = nlohmann::json::object();
  for (const auto& house : houses) {
    transfer.merge(house->transfer);
    r2rCandidates += house->r2r_candidates;
    r2rLength += house->r2r_candidate_length;
    r2rRooms += house->r2r_candidate_rooms;
    for (const Walk& w : house->walks) nodeRooms += w.node_rooms;
    walksDrawn += house->walks_drawn;
    nlohmann::json splits = nlohmann::json::object();
    for (const Walk& w : house->walks)
      splits[w.split] = splits.value(w.split, 0) + 1;
    perHouse[house->name] = {{"role", house->role},
                             {"scene_id", house->scene_id},
                             {"walks_drawn", house->walks_drawn},
                             {"trajectories", splits},
                             {"transfer", house->transfer.toJson()}};
  }
  nlohmann::json splitStats = nlohmann::json::object();
  double allLength = 0.0;
  int allWalks = 0;
  for (const std::string& split : rxrSplitNames()) {
    const Sums& s = sums[split];
    allLength += s.length;
    allWalks += s.walks;
    summary.trajectories[split] = s.walks;
    for (const char* role : {kGuide, kFollower})
      summary.episodes[split][role] =
          static_cast<int>(datasets[split][role].episodes.size());
    splitStats[split] = {
        {"episodes", summary.episodes[split]},
        {"trajectories", s.walks},
        {"mean_graph_path_length", mean(s.length, s.walks)},
        {"mean_geodesic_distance", mean(s.geodesic, s.walks)},
        {"mean_nodes", mean(s.nodes, s.walks)},
        {"mean_rooms_visited", mean(s.rooms, s.walks)},
        {"mean_actions", mean(s.actions, s.walks)},
        {"mean_words", mean(s.words, s.instructions)},
        {"mean_duration_seconds", mean(s.duration, s.instructions)},
        {"languages", s.languages},
    };
  }
  const double r2rMean = mean(r2rLength, r2rCandidates);
  summary.stats = {
      {"seed", config.seed},
      {"houses", n},
      {"transfer", transfer.toJson()},
      {"walks_drawn", walksDrawn},
      {"splits", splitStats},
      {"r2r_comparison",
       {{"r2r_candidates", r2rCandidates},
        {"r2r_mean_candidate_graph_length", r2rMean},
        {"rxr_mean_graph_path_length", mean(allLength, allWalks)},
        {"r2r_mean_candidate_rooms_at_nodes", mean(r2rRooms, r2rCandidates)},
        {"rxr_mean_rooms_at_nodes", mean(nodeRooms, allWalks)},
        {"length_ratio",
         r2rMean > 0.0 ? mean(allLength, allWalks) / r2rMean : 0.0}}},
      {"per_house", perHouse},
      {"config", common::configToYaml(config)},
  };

  // stage every output, then move it into place
  std::error_code ec;
  fs::create_directories(output.out, ec);
  VLN_CHECK_IO(!ec, "generateRxrWorld(): cannot create '", output.out.string(),
               "': ", ec.message());
  const std::string tag = strCat(".generate-rxr-", ::getpid());
  const fs::path staging = output.out / (tag + ".staging");
  const fs::path trash = output.out / (tag + ".old");
  fs::remove_all(staging, ec);
  try {
    for (const std::string& split : rxrSplitNames()) {
      const bool test = split == kTestChallenge;
      for (const char* role : {kGuide, kFollower}) {
        data::writeEpisodes(data::rxrEpisodesPath(staging, split, role),
                            datasets[split][role]);
        const fs::path truthRoot = test ? staging / "hidden" : staging;
        data::writeGroundTruth(data::rxrGroundTruthPath(truthRoot, split, role),
                               truths[split][role]);
        if (test)
          data::writeEpisodes(
              data::rxrEpisodesPath(staging / "hidden", split, role),
              hidden[split][role]);
      }
    }
    for (const auto& house : houses)
      data::writeNavGraph(
          staging / "connectivity" / (house->name + "_connectivity.json"),
          house->graph);
    common::writeJsonFile(staging / "generation_stats.json", summary.stats, 2);
    publishStaged(staging, output.out, trash);
  } catch (...) {
    fs::remove_all(staging, ec);
    throw;
  }

  if (log != nullptr) {
    *log << "generated the RxR split of " << n << " houses into "
         << output.out.string() << "\n";
    for (const std::string& split : rxrSplitNames()) {
      const Sums& s = sums[split];
      *log << "  " << split << ": " << s.walks << " walks, "
           << summary.episodes[split][kGuide] << " guide + "
           << summary.episodes[split][kFollower] << " follower episodes, mean "
           << mean(s.length, s.walks) << " m along the graph, "
           << mean(s.nodes, s.walks) << " nodes, " << mean(s.rooms, s.walks)
           << " rooms, " << mean(s.words, s.instructions) << " words\n";
    }
    *log << "  R2R shortest-path candidates in the same houses: mean "
         << r2rMean << " m (RxR walks / R2R = "
         << summary.stats["r2r_comparison"]["length_ratio"].get<double>()
         << "); rooms at the nodes: R2R " << mean(r2rRooms, r2rCandidates)
         << ", RxR " << mean(nodeRooms, allWalks) << "\n"
         << transfer.report();
  }
  return summary;
}

}  // namespace vln::world
