#include "world/RxrFollower.h"

#include <gtest/gtest.h>

#include <random>
#include <vector>

#include "common/Config.h"
#include "common/Random.h"
#include "data/NodeTransfer.h"
#include "sim/Scene.h"
#include "support/TestPaths.h"
#include "world/RxrWorldConfig.h"
#include "world/WorldGenerator.h"

namespace vln::world {
namespace {

// Legs between random pairs of transferred nodes of the tiny world's first
// house, on the RxR agent's navmesh: the no-sliding follower with detours
// reaches at least as many as the plain shortest-path follower, and its
// actions replay to its recorded locations.
TEST(RxrFollowerTest, DetoursReachMoreGoalsAndReplayExactly) {
  const auto root = test::sourcePath() / "configs" / "world";
  RxrWorldConfig config =
      common::loadConfigFile<RxrWorldConfig>(root / "rxr.yaml");
  config.world = common::loadConfigFile<WorldConfig>(root / "tiny.yaml");
  WorldHouse house = buildWorldHouse(config.world, 0);
  const auto scene =
      sim::Scene::fromMesh(house.name, std::move(house.house.mesh),
                           std::move(house.house.semantics), config.navmesh);
  const sim::NavMesh& navmesh = scene->navmesh();
  const auto transferred =
      data::transferGraph(house.built.graph, navmesh, config.world.transfer);
  std::vector<Vec3f> valid;
  for (const auto& t : transferred)
    if (t.valid) valid.push_back(t.waypoint);
  ASSERT_GT(valid.size(), 5u);

  std::mt19937_64 rng(7);
  int plain = 0, detouring = 0;
  for (int trial = 0; trial < 60; ++trial) {
    const std::vector<Vec3f> waypoints = {
        valid[static_cast<size_t>(
            common::uniformIndex(rng, static_cast<int>(valid.size())))],
        valid[static_cast<size_t>(
            common::uniformIndex(rng, static_cast<int>(valid.size())))]};
    if ((waypoints[0] - waypoints[1]).norm() < 1.0f) continue;
    const float heading = common::uniformRange(rng, -kPi, kPi);
    data::TransferConfig transfer = config.world.transfer;
    transfer.max_leg_detour = 0.0f;
    plain += data::checkNavigability(navmesh, config.agent, transfer, waypoints,
                                     heading)
                 .navigable();
    const data::NavigabilityResult r =
        followRxrWalk(navmesh, config.agent, transfer, waypoints, heading);
    if (!r.navigable()) continue;
    ++detouring;
    sim::AgentState state{waypoints[0], heading};
    size_t location = 1;
    for (const sim::Action a : r.ground_truth.actions) {
      const Vec3f before = state.position;
      sim::applyAction(navmesh, config.agent, state, a);
      if (state.position != before) {
        ASSERT_LT(location, r.ground_truth.locations.size());
        EXPECT_EQ(state.position, r.ground_truth.locations[location++]);
      }
    }
    EXPECT_EQ(location, r.ground_truth.locations.size());
    EXPECT_LE(navmesh.geodesicDistance(state.position, waypoints[1]),
              transfer.follower_goal_radius + 1e-3f);
  }
  EXPECT_GE(detouring, plain);
  EXPECT_GT(detouring, 10);
}

}  // namespace
}  // namespace vln::world
