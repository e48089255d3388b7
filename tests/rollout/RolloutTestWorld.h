#pragma once
// A small generated house shared by the evaluation tests (built once per
// test executable): a scene file, episodes between random navigable points
// 4-9 m apart (geodesic) with reference paths, and their ground truth
// from the shortest-path follower run in the simulator. Cameras are 32x32.
// writeDataset() lays the episodes out as an R2R_VLNCE dataset on disk,
// with the test split's goals in hidden/ as the world generator writes them.

#include <filesystem>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "data/Episode.h"
#include "data/GroundTruth.h"
#include "data/NavGraph.h"
#include "data/Split.h"
#include "sim/Follower.h"
#include "sim/MeshIo.h"
#include "sim/Scene.h"
#include "sim/Simulator.h"
#include "support/TestPaths.h"
#include "world/HouseGenerator.h"

namespace vln::rollout::test {

/// Vocabulary size of the tiny policies that read these instructions.
inline constexpr int kTestVocab = 23;

struct RolloutTestWorld {
  std::unique_ptr<vln::test::TempDir> dir;
  sim::SimConfig sim;
  sim::TaskConfig task;
  std::shared_ptr<const sim::Scene> scene;
  std::vector<data::Episode> episodes;
  /// Follower ground truth of `episodes` (actions end with STOP).
  data::GroundTruth groundTruth;
  /// The follower's positions after reset and after every action, per
  /// episode (what a replaying agent must reproduce).
  std::vector<std::vector<Vec3f>> followerPositions;
};

/// The vocabulary of those tokens: "<pad>", "<unk>", then "word<i>".
inline data::Vocabulary testVocabulary() {
  std::vector<std::string> words = {"<pad>", "<unk>"};
  for (int i = 2; i < kTestVocab; ++i)
    words.push_back("word" + std::to_string(i));
  return data::Vocabulary(words);
}

inline std::vector<int> randomTokens(std::mt19937_64& rng) {
  std::vector<int> tokens(12, 0);
  const int length = 3 + static_cast<int>(rng() % 8);
  for (int i = 0; i < length; ++i)
    tokens[static_cast<size_t>(i)] =
        1 + static_cast<int>(rng() % (kTestVocab - 1));
  return tokens;
}

inline const RolloutTestWorld& rolloutTestWorld() {
  static const RolloutTestWorld world = [] {
    RolloutTestWorld w;
    w.dir = std::make_unique<vln::test::TempDir>();
    world::HouseConfig house;
    house.min_rooms = 3;
    house.max_rooms = 4;
    auto generated = world::generateHouse(/*seed=*/5, house, "h5");
    const auto file = w.dir->path() / "scenes" / "procedural" / "h5" / "h5.glb";
    sim::saveScene(file, generated.mesh, generated.semantics);
    w.sim.scenes_dir = (w.dir->path() / "scenes").string();
    w.sim.rgb = {32, 32, 90.0f, 1.25f};
    w.sim.depth.camera = {32, 32, 90.0f, 1.25f};
    w.task.max_episode_steps = 60;
    w.scene = sim::Scene::load(file, w.sim);
    const sim::NavMesh& navmesh = w.scene->navmesh();

    // episodes between random points 4-9 m apart that the follower solves
    std::mt19937_64 rng(3);
    sim::Simulator simulator(w.scene, w.sim, w.task);
    const sim::ShortestPathFollower follower(navmesh, w.sim.agent,
                                             w.task.follower_goal_radius);
    int id = 100;
    while (w.episodes.size() < 10) {
      const Vec3f start = navmesh.randomPoint(rng, 0);
      const Vec3f goal = navmesh.randomPoint(rng, 0);
      const float d = navmesh.geodesicDistance(start, goal);
      if (!(d >= 4.0f && d <= 9.0f)) continue;
      data::Episode e;
      e.episode_id = id++;
      e.trajectory_id = e.episode_id;
      e.scene_id = "procedural/h5/h5.glb";
      e.start_position = start;
      e.start_rotation =
          headingToQuaternion(static_cast<float>(rng() % 24) * degToRad(15.0f));
      e.geodesic_distance = d;
      e.goals = {data::Goal{goal, 3.0f}};
      e.instruction.instruction_text =
          "walk past the table and stop by the door " +
          std::to_string(e.episode_id);
      e.instruction.instruction_tokens = randomTokens(rng);
      e.reference_path = navmesh.shortestPath(start, goal);

      // the follower's run is the ground truth
      simulator.reset({start, e.startHeading()});
      data::GroundTruthPath path;
      std::vector<Vec3f> positions = {simulator.episode().agent.position};
      path.locations = {simulator.episode().agent.position};
      while (!simulator.episode().done) {
        const sim::Action a =
            follower.nextAction(simulator.episode().agent, goal);
        simulator.step(a);
        path.actions.push_back(a);
        positions.push_back(simulator.episode().agent.position);
        if (a == sim::Action::kMoveForward) {
          path.locations.push_back(simulator.episode().agent.position);
          ++path.forward_steps;
        }
      }
      // keep episodes the follower finishes with STOP within the step limit
      if (path.actions.back() != sim::Action::kStop) continue;
      w.groundTruth[e.episode_id] = path;
      w.followerPositions.push_back(positions);
      w.episodes.push_back(e);
    }
    return w;
  }();
  return world;
}

/// A nav-graph of the house: the corners of every episode's reference path
/// as nodes (merged when closer than 0.3 m), joined along each path.
inline data::NavGraph referenceNavGraph(const RolloutTestWorld& w) {
  data::NavGraph graph;
  auto nodeOf = [&](const Vec3f& p) {
    for (int i = 0; i < graph.numNodes(); ++i)
      if ((graph.node(i).position - p).norm() < 0.3f) return graph.node(i).id;
    // appended rather than "n" + to_string(): GCC 12 at -O3 warns falsely
    // (stringop-overflow) about the operator+ form
    std::string id = "n";
    id += std::to_string(graph.numNodes());
    graph.addNode(id, p);
    return id;
  };
  for (const auto& e : w.episodes) {
    std::string previous;
    for (const Vec3f& p : e.reference_path) {
      const std::string id = nodeOf(p);
      if (!previous.empty() && previous != id) graph.addEdge(previous, id);
      previous = id;
    }
  }
  return graph;
}

/// Writes the episodes as an R2R_VLNCE dataset under `root`: splits
/// val_seen (episodes 0-4, with ground truth), val_unseen (5-9, with
/// ground truth), test (5-9 without goals, reference paths or ground truth)
/// and the train ground truth (all episodes); plus
/// connectivity/h5_connectivity.json.
inline void writeDataset(const RolloutTestWorld& w,
                         const std::filesystem::path& root) {
  auto subset = [&](size_t from, size_t to, bool withGoals) {
    data::EpisodeDataset d;
    d.instruction_vocab = testVocabulary();
    for (size_t i = from; i < to; ++i) {
      data::Episode e = w.episodes[i];
      if (!withGoals) {
        e.goals.clear();
        e.reference_path.clear();
        e.geodesic_distance.reset();
      }
      d.episodes.push_back(e);
    }
    return d;
  };
  auto truthOf = [&](size_t from, size_t to) {
    data::GroundTruth gt;
    for (size_t i = from; i < to; ++i)
      gt[w.episodes[i].episode_id] = w.groundTruth.at(w.episodes[i].episode_id);
    return gt;
  };
  data::writeEpisodes(data::splitEpisodesPath(root, "val_seen"),
                      subset(0, 5, true));
  data::writeGroundTruth(data::splitGroundTruthPath(root, "val_seen"),
                         truthOf(0, 5));
  data::writeEpisodes(data::splitEpisodesPath(root, "val_unseen"),
                      subset(5, 10, true));
  data::writeGroundTruth(data::splitGroundTruthPath(root, "val_unseen"),
                         truthOf(5, 10));
  data::writeEpisodes(data::splitEpisodesPath(root, "test"),
                      subset(5, 10, false));
  // the test split's goals and ground truth, hidden as the world generator
  // hides them (data/Split.h)
  data::writeEpisodes(data::hiddenGoalsPath(root, "test"), subset(5, 10, true));
  data::writeGroundTruth(data::hiddenGroundTruthPath(root, "test"),
                         truthOf(5, 10));
  data::writeEpisodes(data::splitEpisodesPath(root, "train"),
                      subset(0, 10, true));
  data::writeGroundTruth(data::splitGroundTruthPath(root, "train"),
                         truthOf(0, 10));
  data::writeNavGraph(root / "connectivity" / "h5_connectivity.json",
                      referenceNavGraph(w));
}

}  // namespace vln::rollout::test
