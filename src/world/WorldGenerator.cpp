#include "world/WorldGenerator.h"

#include <spdlog/spdlog.h>

#include <unistd.h>
#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <exception>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <system_error>
#include <thread>

#include "common/Check.h"
#include "common/Config.h"
#include "common/FileIo.h"
#include "common/Json.h"
#include "common/Progress.h"
#include "common/Random.h"
#include "data/Episode.h"
#include "data/GloveFit.h"
#include "data/GroundTruth.h"
#include "data/Split.h"
#include "data/SubInstructions.h"
#include "data/Vocabulary.h"
#include "sim/MeshIo.h"
#include "sim/RayTracer.h"
#include "sim/Scene.h"
#include "world/CaptureDifferences.h"
#include "world/HouseGenerator.h"
#include "world/InstructionGenerator.h"
#include "world/NavGraphBuilder.h"
#include "world/TrajectorySampler.h"

namespace vln::world {

namespace {

namespace fs = std::filesystem;

// Stream labels for common::deriveSeed(): every stage of a house draws from its
// own generator.
enum Stream : uint64_t {
  kHouseStream = 0x686f757365ull,  // "house"
  kSplitStream = 0x73706c6974ull,  // "split"
  kGraphStream = 1,
  kOrderStream = 2,
  kHeadingStream = 3,
  kInstructionStream = 4,
  kReconstructionStream = 5,
};

constexpr const char* kTrain = "train";
constexpr const char* kValSeen = "val_seen";
constexpr const char* kValUnseen = "val_unseen";
constexpr const char* kTest = "test";
constexpr const char* kTrainAug = "train_aug";
constexpr const char* kTrainExtra = "train_extra";
constexpr const char* kValUnseenExtra = "val_unseen_extra";

// ---------------------------------------------------------------------------
// per house
// ---------------------------------------------------------------------------

// One kept trajectory with everything an episode needs.
struct Trajectory {
  std::string split;
  std::vector<Vec3f> waypoints;  // transferred reference path
  float start_heading = 0.0f;
  float geodesic = 0.0f;
  double graph_length = 0.0;  // along nav-graph edges, metres
  data::GroundTruthPath ground_truth;
  std::vector<std::string> instructions;
  // per instruction, its clauses and the legs they describe
  std::vector<std::vector<data::SubInstruction>> sub_instructions;
};

struct HouseResult {
  std::string name;
  std::string scene_id;
  std::string role;
  data::NavGraph graph;
  std::map<std::string, int> placements;
  // per placement kind: transfer outcome of its nodes
  std::map<std::string, data::TransferStats> placementTransfer;
  int holes_found = 0;
  int closed_doors = 0;
  int moved_objects = 0;
  int largest_component = 0;
  int candidates = 0;
  data::TransferStats transfer;
  std::vector<Trajectory> trajectories;  // in acceptance order
};

uint64_t houseSeed(const WorldConfig& config, int index) {
  return common::deriveSeed(
      common::deriveSeed(static_cast<uint64_t>(config.seed), kHouseStream),
      static_cast<uint64_t>(index));
}

// Split quotas of a house of role `role`, in filling priority order.
std::vector<std::pair<std::string, int>> quotas(const WorldConfig& config,
                                                const std::string& role) {
  const SplitConfig& s = config.splits;
  if (role == kTrain)
    return {{kTrain, s.train_per_house},
            {kValSeen, s.val_seen_per_house},
            {kTrainAug, s.aug_per_house}};
  if (role == kValUnseen) return {{kValUnseen, s.val_unseen_per_house}};
  if (role == kTrainExtra) return {{kTrainExtra, s.train_per_house}};
  if (role == kValUnseenExtra)
    return {{kValUnseenExtra, s.val_unseen_per_house}};
  return {{kTest, s.test_per_house}};
}

HouseResult processHouse(const WorldConfig& config, const WorldOutput& output,
                         int index, const std::string& role) {
  HouseResult result;
  result.role = role;
  // the house as captured, its nav-graph and the reconstruction agents move
  // in; saved as a scene with its navmesh beside it (written after the scene
  // so that the cache is never older than the file it belongs to)
  WorldHouse captured = buildWorldHouse(config, index);
  House& house = captured.house;
  const uint64_t seed = captured.seed;
  result.name = captured.name;
  result.scene_id = captured.scene_id;
  result.closed_doors = captured.differences.closed_doors;
  result.moved_objects = captured.differences.moved_objects;
  const fs::path sceneFile = output.scenes_dir / result.scene_id;
  sim::saveScene(sceneFile, house.mesh, house.semantics);
  const auto scene =
      sim::Scene::fromMesh(result.name, std::move(house.mesh),
                           std::move(house.semantics), config.navmesh);
  fs::path navmeshFile = sceneFile;
  navmeshFile += ".navmesh";
  scene->navmesh().save(navmeshFile);
  const sim::NavMesh& navmesh = scene->navmesh();

  // the panoramas' transfer to the navmesh
  for (const NodePlacement p : captured.built.placement)
    ++result.placements[nodePlacementName(p)];
  result.holes_found = captured.built.holes_found;
  const auto components = componentSizes(captured.built.graph);
  result.largest_component = components.empty() ? 0 : components.front();
  const std::vector<data::NodeTransferResult> transferred =
      data::transferGraph(captured.built.graph, navmesh, config.transfer);
  result.transfer.addNodes(transferred, config.transfer);
  for (size_t i = 0; i < transferred.size(); ++i)
    result.placementTransfer[nodePlacementName(captured.built.placement[i])]
        .addNodes({transferred[i]}, config.transfer);

  // R2R-like trajectories in a seeded order; the navigable ones fill the
  // splits of this house, each taking the next one while it is the least
  // filled relative to its quota
  const TrajectorySampler sampler(captured.built.graph, config.trajectories);
  result.candidates = sampler.size();
  auto splits = quotas(config, role);
  std::vector<int> filled(splits.size(), 0);
  int wanted = 0;
  for (const auto& [name, quota] : splits) wanted += quota;
  const InstructionGenerator instructions(scene->semantics(),
                                          config.instructions);
  for (const int candidate :
       sampler.shuffledOrder(common::deriveSeed(seed, kOrderStream))) {
    if (wanted == 0) break;
    const GraphPath& path = sampler.candidate(candidate);
    std::mt19937_64 headingRng(
        common::deriveSeed(common::deriveSeed(seed, kHeadingStream),
                           static_cast<uint64_t>(candidate)));
    const float heading = common::uniformRange(headingRng, -kPi, kPi);
    data::NavigabilityResult checked = data::checkNavigability(
        navmesh, config.agent, config.transfer, transferred, path, heading);
    result.transfer.addTrajectory(checked);
    if (!checked.navigable()) continue;

    size_t pick = splits.size();
    for (size_t k = 0; k < splits.size(); ++k) {
      if (filled[k] >= splits[k].second) continue;
      if (pick == splits.size() ||
          static_cast<int64_t>(filled[k]) * splits[pick].second <
              static_cast<int64_t>(filled[pick]) * splits[k].second)
        pick = k;
    }
    VLN_ASSERT(pick < splits.size());
    ++filled[pick];
    --wanted;

    Trajectory t;
    t.split = splits[pick].first;
    for (const int node : path)
      t.waypoints.push_back(transferred[static_cast<size_t>(node)].waypoint);
    t.start_heading = heading;
    t.geodesic = checked.geodesic_distance;
    t.graph_length = pathLength(captured.built.graph, path);
    t.ground_truth = std::move(checked.ground_truth);
    const bool aug = t.split == kTrainAug;
    const auto generated = instructions.generate(
        t.waypoints, heading,
        aug ? InstructionStyle::kSpeaker : InstructionStyle::kHuman,
        aug ? config.instructions.aug_per_trajectory
            : config.instructions.per_trajectory,
        common::deriveSeed(common::deriveSeed(seed, kInstructionStream),
                           static_cast<uint64_t>(candidate)));
    for (const auto& g : generated) {
      t.instructions.push_back(g.text);
      t.sub_instructions.push_back(g.sub_instructions);
    }
    result.trajectories.push_back(std::move(t));
  }
  result.graph = std::move(captured.built.graph);
  return result;
}

// ---------------------------------------------------------------------------
// house roles
// ---------------------------------------------------------------------------

}  // namespace

std::vector<std::string> worldHouseRoles(const WorldConfig& config) {
  const int n = config.houses;
  auto count = [&](float fraction) {
    int c = static_cast<int>(std::lround(fraction * static_cast<float>(n)));
    // a held-out split with a non-zero share gets at least one house when
    // there are three houses or more
    if (fraction > 0.0f && c == 0 && n >= 3) c = 1;
    return c;
  };
  const int valUnseen = count(config.splits.val_unseen_fraction);
  const int test = count(config.splits.test_fraction);
  VLN_CHECK_ARG(n - valUnseen - test >= 1, "generateWorld(): ", n,
                " houses leave no train house after ", valUnseen,
                " val_unseen and ", test, " test houses");
  std::vector<int> order(static_cast<size_t>(n));
  for (int i = 0; i < n; ++i) order[static_cast<size_t>(i)] = i;
  std::mt19937_64 rng(
      common::deriveSeed(static_cast<uint64_t>(config.seed), kSplitStream));
  common::deterministicShuffle(order, rng);
  std::vector<std::string> roles(static_cast<size_t>(n), kTrain);
  for (int k = 0; k < valUnseen + test; ++k)
    roles[static_cast<size_t>(order[static_cast<size_t>(k)])] =
        k < valUnseen ? kValUnseen : kTest;
  // the extra houses come after, so the first `houses` keep their roles
  roles.resize(static_cast<size_t>(n + config.splits.extra_train_houses),
               kTrainExtra);
  roles.resize(roles.size() +
                   static_cast<size_t>(config.splits.extra_unseen_houses),
               kValUnseenExtra);
  return roles;
}

int worldHouseIndex(const WorldConfig& config, int slot) {
  const int extraUnseenSlot = config.houses + config.splits.extra_train_houses;
  return slot < extraUnseenSlot ? slot
                                : kExtraUnseenFirstIndex + (slot - extraUnseenSlot);
}

WorldHouse buildWorldHouse(const WorldConfig& config, int index) {
  WorldHouse result;
  result.name = worldHouseName(config, index);
  result.scene_id =
      strCat(config.scene_prefix, "/", result.name, "/", result.name, ".glb");
  result.seed = houseSeed(config, index);

  // the house as the panoramas captured it, and its nav-graph
  result.house = generateHouse(result.seed, config.house, result.name);
  {
    const sim::RayTracer tracer(result.house.mesh);
    result.built =
        buildNavGraph(result.house.semantics, tracer, config.nav_graph,
                      common::deriveSeed(result.seed, kGraphStream));
  }

  // the reconstruction differs a little, and is what agents move in
  result.differences = applyCaptureDifferences(
      result.house, result.built, config,
      common::deriveSeed(result.seed, kReconstructionStream));
  return result;
}

namespace {

// ---------------------------------------------------------------------------
// staging and publishing
// ---------------------------------------------------------------------------

}  // namespace

void publishStaged(const fs::path& staging, const fs::path& out,
                   const fs::path& trash) {
  std::vector<fs::path> entries;
  for (const auto& entry : fs::directory_iterator(staging))
    entries.push_back(entry.path().filename());
  std::sort(entries.begin(), entries.end());
  fs::create_directories(trash);
  for (const fs::path& name : entries) {
    std::error_code ec;
    if (fs::exists(out / name)) {
      fs::rename(out / name, trash / name, ec);
      VLN_CHECK_IO(!ec, "generateWorld(): cannot move aside '",
                   (out / name).string(), "': ", ec.message());
    }
    fs::rename(staging / name, out / name, ec);
    VLN_CHECK_IO(!ec, "generateWorld(): cannot move '",
                 (staging / name).string(), "' into place: ", ec.message());
  }
  common::syncDirectory(out);
  std::error_code ignored;
  fs::remove_all(trash, ignored);
  fs::remove_all(staging, ignored);
}

namespace {

double mean(double sum, int64_t count) {
  return count > 0 ? sum / static_cast<double>(count) : 0.0;
}

}  // namespace

// ===========================================================================
// public API
// ===========================================================================

const std::vector<std::string>& worldSplitNames() {
  static const std::vector<std::string> kNames = {kTrain, kValSeen, kValUnseen,
                                                  kTest, kTrainAug};
  return kNames;
}

std::string worldHouseName(const WorldConfig& config, int index) {
  const uint64_t hash = common::mixBits(
      houseSeed(config, index) ^
      common::fnv1a(common::configToYaml(config.house)) ^
      common::mixBits(common::fnv1a(common::configToYaml(config.navmesh))));
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), "house_%03d_%08llx", index,
                static_cast<unsigned long long>(hash >> 32));
  return buffer;
}

void forEachWorldHouse(const WorldConfig& config, int houses, int threads,
                       const char* label, const char* caller,
                       const std::function<void(int)>& process) {
  std::vector<std::exception_ptr> errors(static_cast<size_t>(houses));
  std::atomic<int> next{0};
  std::mutex progressMutex;
  common::ProgressLine progress(label, houses, "houses", 10.0);
  auto worker = [&] {
    for (int i = next++; i < houses; i = next++) {
      // errors name the house; their type (bad input or I/O) is kept
      const std::string where =
          strCat(caller, ": house ", worldHouseIndex(config, i), " '",
                 worldHouseName(config, worldHouseIndex(config, i)), "': ");
      try {
        process(i);
      } catch (const std::invalid_argument& e) {
        errors[static_cast<size_t>(i)] =
            std::make_exception_ptr(std::invalid_argument(where + e.what()));
      } catch (const std::exception& e) {
        errors[static_cast<size_t>(i)] =
            std::make_exception_ptr(std::runtime_error(where + e.what()));
      }
      if (errors[static_cast<size_t>(i)])
        next = houses;  // stop handing out work
      std::lock_guard lock(progressMutex);
      progress.advance();
    }
  };
  std::vector<std::thread> pool;
  for (int t = 1; t < std::min(threads, houses); ++t) pool.emplace_back(worker);
  worker();
  for (auto& thread : pool) thread.join();
  for (const auto& error : errors)
    if (error) std::rethrow_exception(error);
}

WorldSummary generateWorld(const WorldConfig& config, const WorldOutput& output,
                           std::ostream* log) {
  WorldConfig checked = config;  // visit() is non-const
  common::checkConfig([&](common::ConfigVisitor& v) { checked.visit(v); },
                      "generateWorld()");
  config.validate();
  VLN_CHECK_ARG(output.threads >= 1,
                "generateWorld(): threads must be >= 1, got ", output.threads);
  VLN_CHECK_ARG(!output.out.empty(),
                "generateWorld(): the output directory is empty");
  const std::vector<std::string> roles = worldHouseRoles(config);

  // the splits written: train_extra and val_unseen_extra only when there
  // are such houses, and last, so that the trajectory ids of the others do
  // not depend on them
  std::vector<std::string> splitNames = worldSplitNames();
  if (config.splits.extra_train_houses > 0) splitNames.push_back(kTrainExtra);
  if (config.splits.extra_unseen_houses > 0)
    splitNames.push_back(kValUnseenExtra);

  // houses on a pool of threads; results land in house order
  const int n = static_cast<int>(roles.size());
  std::vector<std::optional<HouseResult>> houses(static_cast<size_t>(n));
  forEachWorldHouse(
      config, n, output.threads, "generate", "generateWorld()", [&](int i) {
        houses[static_cast<size_t>(i)] =
            processHouse(config, output, worldHouseIndex(config, i),
                         roles[static_cast<size_t>(i)]);
      });

  // episodes of every split, merged in house order
  std::map<std::string, data::EpisodeDataset> datasets;
  std::map<std::string, data::GroundTruth> truths;
  // the test split is published without goals; they and its ground truth
  // go to hidden/test/ (data/Split.h), for the eval binary only
  data::EpisodeDataset hiddenTest;
  data::GroundTruth hiddenTruth;
  std::map<std::string, int> trajectoryCount;
  std::map<std::string, double> pathLength, geodesic, actions, tokens,
      unknownTokens;
  std::vector<std::string> trainCorpus;
  // for the training splits: an agent is not told how its instruction
  // divides; the evaluation splits' (never test's) on request, as new files
  // beside their frozen ones, for diagnostics
  std::map<std::string, data::SubInstructions> subInstructions;
  const bool evaluationSubInstructions =
      config.splits.evaluation_sub_instructions;
  int trajectoryId = 0;
  for (const std::string& split : splitNames) {
    int episodeId = 0;
    for (const auto& house : houses) {
      for (const Trajectory& t : house->trajectories) {
        if (t.split != split) continue;
        ++trajectoryId;
        ++trajectoryCount[split];
        pathLength[split] += t.graph_length;
        geodesic[split] += t.geodesic;
        actions[split] += static_cast<double>(t.ground_truth.actions.size());
        for (size_t k = 0; k < t.instructions.size(); ++k) {
          const std::string& text = t.instructions[k];
          data::Episode e;
          e.episode_id = ++episodeId;
          e.trajectory_id = trajectoryId;
          e.scene_id = house->scene_id;
          e.start_position = t.waypoints.front();
          e.start_rotation = headingToQuaternion(t.start_heading);
          e.instruction.instruction_text = text;
          data::Episode withGoals = e;
          withGoals.geodesic_distance = t.geodesic;
          withGoals.goals = {
              data::Goal{t.waypoints.back(), data::kDefaultGoalRadius}};
          withGoals.reference_path = t.waypoints;
          if (split == kTest) {
            hiddenTest.episodes.push_back(std::move(withGoals));
            hiddenTruth[e.episode_id] = t.ground_truth;
          } else {
            e = std::move(withGoals);
            truths[split][e.episode_id] = t.ground_truth;
          }
          if (split == kTrain || split == kTrainAug)
            trainCorpus.push_back(text);
          if (split == kTrain || split == kTrainAug || split == kTrainExtra ||
              (evaluationSubInstructions && split != kTest))
            subInstructions[split][e.episode_id] = t.sub_instructions[k];
          datasets[split].episodes.push_back(std::move(e));
        }
      }
    }
  }
  for (const std::string& split : splitNames) {
    int wanted = 0;
    for (size_t i = 0; i < roles.size(); ++i)
      for (const auto& [name, quota] : quotas(config, roles[i]))
        if (name == split) wanted += quota;
    VLN_CHECK_IO(wanted == 0 || !datasets[split].episodes.empty(),
                 "generateWorld(): split '", split,
                 "' got no navigable trajectory; the world is too small for "
                 "its quotas (houses ",
                 config.houses, ", nodes per house too few?)");
  }

  // the vocabulary and GloVe of the training corpus (train + train_aug)
  const data::Vocabulary vocabulary = data::Vocabulary::build(trainCorpus);
  for (auto& [split, dataset] : datasets) {
    for (data::Episode& e : dataset.episodes) {
      e.instruction.instruction_tokens =
          vocabulary.encode(e.instruction.instruction_text);
      tokens[split] += data::unpaddedLength(e.instruction.instruction_tokens,
                                            vocabulary.padIndex());
      for (const int token : e.instruction.instruction_tokens)
        if (token == vocabulary.unkIndex()) unknownTokens[split] += 1.0;
    }
    dataset.instruction_vocab = vocabulary;
  }
  for (data::Episode& e : hiddenTest.episodes)
    e.instruction.instruction_tokens =
        vocabulary.encode(e.instruction.instruction_text);
  hiddenTest.instruction_vocab = vocabulary;
  std::vector<std::vector<std::string>> sentences;
  sentences.reserve(trainCorpus.size());
  for (const std::string& text : trainCorpus)
    sentences.push_back(data::tokenize(text));
  const data::GloveFitResult glove = data::fitGlove(sentences, config.glove);
  const data::EmbeddingMatrix embeddings =
      data::buildEmbeddingMatrix(vocabulary, glove.vectors);

  // statistics
  WorldSummary summary;
  nlohmann::json perHouse = nlohmann::json::object();
  std::map<std::string, int64_t> placements;
  std::map<std::string, data::TransferStats> placementTransfer;
  int64_t nodes = 0, edges = 0, largest = 0, holes = 0, candidates = 0;
  int64_t closedDoors = 0, movedObjects = 0;
  for (const auto& house : houses) {
    summary.transfer.merge(house->transfer);
    summary.houses[house->role].push_back(house->name);
    nodes += house->graph.numNodes();
    edges += house->graph.numEdges();
    largest += house->largest_component;
    holes += house->holes_found;
    closedDoors += house->closed_doors;
    movedObjects += house->moved_objects;
    candidates += house->candidates;
    for (const auto& [name, count] : house->placements)
      placements[name] += count;
    for (const auto& [name, stats] : house->placementTransfer)
      placementTransfer[name].merge(stats);
    nlohmann::json splits = nlohmann::json::object();
    for (const Trajectory& t : house->trajectories)
      splits[t.split] = splits.value(t.split, 0) + 1;
    perHouse[house->name] = {{"role", house->role},
                             {"scene_id", house->scene_id},
                             {"nodes", house->graph.numNodes()},
                             {"edges", house->graph.numEdges()},
                             {"largest_component", house->largest_component},
                             {"closed_doors", house->closed_doors},
                             {"moved_objects", house->moved_objects},
                             {"candidate_trajectories", house->candidates},
                             {"trajectories", splits},
                             {"transfer", house->transfer.toJson()}};
  }
  nlohmann::json splitStats = nlohmann::json::object();
  for (const std::string& split : splitNames) {
    const int trajectories = trajectoryCount[split];
    const int episodes = static_cast<int>(datasets[split].episodes.size());
    summary.episodes[split] = episodes;
    summary.trajectories[split] = trajectories;
    splitStats[split] = {
        {"episodes", episodes},
        {"trajectories", trajectories},
        {"mean_instruction_tokens", mean(tokens[split], episodes)},
        {"unknown_tokens", static_cast<int64_t>(unknownTokens[split])},
        {"mean_graph_path_length", mean(pathLength[split], trajectories)},
        {"mean_geodesic_distance", mean(geodesic[split], trajectories)},
        {"mean_actions", mean(actions[split], trajectories)},
    };
  }
  summary.vocabulary_size = vocabulary.size();
  nlohmann::json placementJson = nlohmann::json::object();
  for (const auto& [name, stats] : placementTransfer) {
    const nlohmann::json full = stats.toJson();
    placementJson[name] = {
        {"nodes", full["nodes"]},
        {"nodes_valid", full["nodes_valid"]},
        {"nodes_adjusted", full["nodes_adjusted"]},
        {"mean_adjusted_displacement", full["mean_adjusted_displacement"]}};
  }
  summary.stats = {
      {"seed", config.seed},
      {"houses", config.houses},
      {"house_roles", summary.houses},
      {"transfer", summary.transfer.toJson()},
      {"nav_graph",
       {{"nodes", nodes},
        {"edges", edges},
        {"mean_nodes_per_house", mean(static_cast<double>(nodes), n)},
        {"largest_component_share", mean(static_cast<double>(largest), nodes)},
        {"placements", placements},
        {"placement_transfer", placementJson},
        {"floor_holes_found", holes},
        {"closed_doors", closedDoors},
        {"moved_objects", movedObjects},
        {"candidate_trajectories", candidates}}},
      {"splits", splitStats},
      {"vocabulary_size", vocabulary.size()},
      {"glove",
       {{"dim", config.glove.dim},
        {"final_loss",
         glove.epoch_loss.empty() ? 0.0 : glove.epoch_loss.back()},
        {"cooccurrence_entries", glove.cooccurrence_entries}}},
      {"per_house", perHouse},
      {"config", common::configToYaml(config)},
  };

  // stage every output, then move it into place
  std::error_code ec;
  fs::create_directories(output.out, ec);
  VLN_CHECK_IO(!ec, "generateWorld(): cannot create '", output.out.string(),
               "': ", ec.message());
  const std::string tag = strCat(".generate-", ::getpid());
  const fs::path staging = output.out / (tag + ".staging");
  const fs::path trash = output.out / (tag + ".old");
  fs::remove_all(staging, ec);
  try {
    for (const std::string& split : splitNames) {
      data::writeEpisodes(data::splitEpisodesPath(staging, split),
                          datasets[split]);
      if (split != kTest)
        data::writeGroundTruth(data::splitGroundTruthPath(staging, split),
                               truths[split]);
      if (subInstructions.count(split) != 0)
        data::writeSubInstructions(
            data::splitSubInstructionsPath(staging, split),
            subInstructions[split]);
    }
    data::writeEpisodes(data::hiddenGoalsPath(staging, kTest), hiddenTest);
    data::writeGroundTruth(data::hiddenGroundTruthPath(staging, kTest),
                           hiddenTruth);
    data::writeEmbeddingsJson(staging / "embeddings.json.gz", embeddings);
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
    *log << "generated " << n << " houses (" << summary.houses["train"].size()
         << " train, " << summary.houses["val_unseen"].size() << " val_unseen, "
         << summary.houses["test"].size() << " test"
         << (summary.houses.count(kTrainExtra) != 0
                 ? strCat(", ", summary.houses[kTrainExtra].size(),
                          " extra train")
                 : std::string())
         << (summary.houses.count(kValUnseenExtra) != 0
                 ? strCat(", ", summary.houses[kValUnseenExtra].size(),
                          " extra val_unseen")
                 : std::string())
         << ") into " << output.out.string() << "\n";
    for (const std::string& split : splitNames)
      *log << "  " << split << ": " << summary.episodes[split] << " episodes, "
           << summary.trajectories[split] << " trajectories\n";
    *log << "  vocabulary: " << vocabulary.size() << " words\n"
         << summary.transfer.report();
  }
  return summary;
}

}  // namespace vln::world
