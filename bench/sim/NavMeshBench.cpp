// Navmesh speed: build time of a few-room house, geodesic queries per
// second (one and two threads), agent steps per second and oracle actions
// per second.

#include <benchmark/benchmark.h>

#include <memory>
#include <random>
#include <utility>
#include <vector>

#include "sim/Agent.h"
#include "sim/Follower.h"
#include "sim/NavMesh.h"
#include "sim/SimTestScenes.h"

namespace vln::sim {
namespace {

using test::addBox;
using test::kWallTop;
using test::wallAlongX;
using test::wallAlongZ;

// A 16 x 10 m house: a row of four 4 m rooms joined by doorways and a
// corridor-like south strip, with pillars and tables. Roughly an MP3D
// apartment floor in extent.
TriangleMesh fewRoomHouse() {
  TriangleMesh m;
  test::addWalledFloor(m, 16, 10);
  // rooms in the north 7 m, a 3 m hall along the south
  for (int r = 1; r < 4; ++r) {
    const float x = 4.0f * static_cast<float>(r);
    wallAlongZ(m, x, 0, 3.0f + static_cast<float>(r % 2));
    wallAlongZ(m, x, 4.2f + static_cast<float>(r % 2), 7);
  }
  for (int r = 0; r < 4; ++r) {
    const float x0 = 4.0f * static_cast<float>(r);
    wallAlongX(m, 7, x0, x0 + 1.2f);  // doorway to the hall in [x0+1.2, x0+2.4]
    wallAlongX(m, 7, x0 + 2.4f, x0 + 4.0f);
    addBox(m, {x0 + 2.5f, 0, 1.0f}, {x0 + 3.3f, 0.75f, 2.2f});  // table
    addBox(m, {x0 + 1.0f, 0, 4.5f}, {x0 + 1.4f, kWallTop, 4.9f});   // pillar
  }
  return m;
}

const NavMesh& house() {
  static const auto navmesh = NavMesh::build(fewRoomHouse(), NavMeshConfig{});
  return *navmesh;
}

std::vector<std::pair<Vec3f, Vec3f>> randomPairs(int count) {
  std::mt19937_64 rng(1);
  std::vector<std::pair<Vec3f, Vec3f>> pairs;
  for (int i = 0; i < count; ++i)
    pairs.emplace_back(house().randomPoint(rng, 0),
                       house().randomPoint(rng, 0));
  return pairs;
}

void BM_BuildFewRoomHouse(benchmark::State& state) {
  const TriangleMesh mesh = fewRoomHouse();
  int polygons = 0;
  for (auto _ : state) {
    const auto navmesh = NavMesh::build(mesh, NavMeshConfig{});
    polygons = navmesh->polygonCount();
    benchmark::DoNotOptimize(navmesh.get());
  }
  state.counters["polygons"] = polygons;
  state.counters["triangles"] = static_cast<double>(mesh.triangleCount());
}
BENCHMARK(BM_BuildFewRoomHouse)->Unit(benchmark::kMillisecond);

void BM_GeodesicDistance(benchmark::State& state) {
  static const auto pairs = randomPairs(1024);
  size_t i = 0;
  for (auto _ : state) {
    const auto& [a, b] = pairs[i++ % pairs.size()];
    benchmark::DoNotOptimize(house().geodesicDistance(a, b));
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_GeodesicDistance)->Threads(1)->Threads(2)->UseRealTime();

void BM_SaveLoadRoundTrip(benchmark::State& state) {
  const auto file =
      std::filesystem::temp_directory_path() / "vln_navmesh_bench.navmesh";
  for (auto _ : state) {
    house().save(file);
    benchmark::DoNotOptimize(NavMesh::load(file).get());
  }
  std::filesystem::remove(file);
}
BENCHMARK(BM_SaveLoadRoundTrip)->Unit(benchmark::kMillisecond);

void BM_AgentSteps(benchmark::State& state) {
  // a random walk, 60% forward (VLN-CE's oracle paths are mostly forward)
  const AgentConfig agent;
  TaskConfig task;
  std::mt19937_64 rng(2);
  std::mt19937_64 pointRng(3);
  EpisodeState episode;
  episode.agent.position = house().randomPoint(pointRng, 0);
  for (auto _ : state) {
    if (episode.done) {
      episode = EpisodeState{};
      episode.agent.position = house().randomPoint(pointRng, 0);
    }
    const uint64_t r = rng() % 10;
    const Action action = r < 6   ? Action::kMoveForward
                          : r < 8 ? Action::kTurnLeft
                                  : Action::kTurnRight;
    benchmark::DoNotOptimize(
        stepEpisode(house(), agent, task, episode, action));
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_AgentSteps);

void BM_FollowerEpisodes(benchmark::State& state) {
  // oracle action + step, the inner loop of teacher forcing and DAgger
  const AgentConfig agent;
  const TaskConfig task;
  const ShortestPathFollower follower(house(), agent,
                                      task.follower_goal_radius);
  static const auto pairs = randomPairs(256);
  size_t next = 0;
  EpisodeState episode;
  episode.done = true;
  Vec3f goal = Vec3f::Zero();
  for (auto _ : state) {
    if (episode.done) {
      episode = EpisodeState{};
      episode.agent.position = pairs[next % pairs.size()].first;
      goal = pairs[next % pairs.size()].second;
      ++next;
    }
    stepEpisode(house(), agent, task, episode,
                follower.nextAction(episode.agent, goal));
  }
  state.SetItemsProcessed(state.iterations());
  state.counters["episodes"] = static_cast<double>(next);
}
BENCHMARK(BM_FollowerEpisodes);

}  // namespace
}  // namespace vln::sim
