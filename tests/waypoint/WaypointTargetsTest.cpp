// Tests src/waypoint/WaypointTargets.cpp: open distances in a room of known
// size, the Gaussian target heatmap worked out by hand, and a node's targets
// from a hand-built graph (range, one per heading bin, masking, dropping).

#include "waypoint/WaypointTargets.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>

#include "sim/SimTestScenes.h"
#include "sim/SimTestSuites.h"

namespace vln::waypoint {
namespace {

using ::testing::HasSubstr;

// A closed 6 m x 6 m room (walls at x, z = +-3) with a 1 m cube spanning
// x in [1.5, 2.5], z in [-0.5, 0.5] (tests/sim/SimTestScenes.h).
std::shared_ptr<const sim::Scene> room() {
  return test::roomWithCube("targets-room", /*ceiling=*/false);
}

class WaypointTargetsTest : public test::SceneSuite<room> {
 protected:
  // the agent's feet on the navmesh at (x, z)
  static Vec3f feet(float x, float z) {
    return *scene_->navmesh().snapPoint({x, 0.0f, z});
  }
};

TEST_F(WaypointTargetsTest, OpenDistancesReachTheWallsLessTheAgentRadius) {
  const sim::AgentState agent{feet(-1.0f, 0.0f), 0.0f};
  const auto open = openDistances(scene_->navmesh(), sim::AgentConfig{}, agent);
  // the navmesh keeps agent_radius (0.1 m) from walls, to a cell or so:
  // ahead (-Z) the wall is 3 m away, left (-X) 2 m, right (+X) the cube at
  // 2.5 m, behind 3 m
  EXPECT_NEAR(open[0], 2.9f, 0.08f);
  EXPECT_NEAR(open[30], 1.9f, 0.08f);
  EXPECT_NEAR(open[60], 2.9f, 0.08f);
  EXPECT_NEAR(open[90], 2.4f, 0.08f);
  // the heading is relative: turned left by 90 degrees, bin 0 is the -X wall
  const auto turned = openDistances(scene_->navmesh(), sim::AgentConfig{},
                                    {agent.position, kPi / 2.0f});
  EXPECT_NEAR(turned[0], open[30], 1e-4f);
  EXPECT_NEAR(turned[90], open[0], 1e-4f);
}

TEST(TargetHeatmapTest, GaussianAroundEachTargetThenMasked) {
  std::array<float, kNumHeadings> open;
  open.fill(3.0f);
  open[60] = 1.0f;  // cells 0..3 open along bin 60
  std::vector<TargetWaypoint> targets(2);
  targets[0].heading_bin = 0;
  targets[0].distance_bin = 4;
  targets[1].heading_bin = 60;
  targets[1].distance_bin = 8;
  const std::vector<float> heatmap =
      targetHeatmap(targets, open, WaypointTargetConfig{});
  ASSERT_EQ(heatmap.size(), static_cast<size_t>(kHeatmapSize));
  const auto at = [&](int h, int d) {
    return heatmap[static_cast<size_t>(h * kNumDistances + d)];
  };
  // peak 1 at the target; one sigma away (1 heading bin, 2 distance bins)
  // the Gaussian is exp(-1/2) of it, across the wrap too
  EXPECT_NEAR(at(0, 4), 1.0f, 1e-6f);
  EXPECT_NEAR(at(1, 4), std::exp(-0.5f), 1e-5f);
  EXPECT_NEAR(at(119, 4), std::exp(-0.5f), 1e-5f);
  EXPECT_NEAR(at(0, 6), std::exp(-0.5f), 1e-5f);
  EXPECT_NEAR(at(0, 2), std::exp(-0.5f), 1e-5f);
  // the second target lies behind an obstacle: zeroed, as are the cells
  // beyond 1 m along its heading, but not those before
  EXPECT_EQ(at(60, 8), 0.0f);
  EXPECT_EQ(at(60, 4), 0.0f);
  EXPECT_NEAR(at(60, 3), std::exp(-0.5f * 25.0f / 4.0f), 1e-5f);
  EXPECT_GT(at(61, 8), 0.5f);
  // no targets, no heatmap
  const auto empty = targetHeatmap({}, open, WaypointTargetConfig{});
  EXPECT_EQ(*std::max_element(empty.begin(), empty.end()), 0.0f);
}

TEST_F(WaypointTargetsTest, NodeTargetsFromTheGraph) {
  // node a at (-1, 0) facing -Z; neighbours: b 2 m ahead, c 1 m ahead in
  // the same heading bin (the farther b wins), d 1.5 m left, e 4 m behind
  // (out of range), f not transferred; g is no neighbour
  // only the agent's own node must lie on the navmesh (it walks from
  // there); the others' transferred positions are given
  const Vec3f a = feet(-1.0f, 0.0f);
  const Vec3f up(0.0f, 1.5f, 0.0f);
  data::NavGraph graph;
  graph.addNode("a", a + up);
  graph.addNode("b", a + up + Vec3f(0.0f, 0.0f, -2.0f));
  graph.addNode("c", a + up + Vec3f(0.0f, 0.0f, -1.0f));
  graph.addNode("d", a + up + Vec3f(-1.5f, 0.0f, 0.0f));
  graph.addNode("e", a + up + Vec3f(0.0f, 0.0f, 4.0f));
  graph.addNode("f", a + up + Vec3f(1.0f, 0.0f, 0.0f));
  graph.addNode("g", a + up + Vec3f(0.0f, 0.0f, 1.0f));
  for (const char* n : {"b", "c", "d", "e", "f"}) graph.addEdge("a", n);
  std::vector<data::NodeTransferResult> transferred(7);
  for (int i = 0; i < 7; ++i) {
    transferred[static_cast<size_t>(i)].valid = i != 5;
    transferred[static_cast<size_t>(i)].waypoint = graph.node(i).position - up;
  }

  const NodeTargets node =
      nodeTargets(graph, transferred, 0, /*heading=*/0.0f, scene_->navmesh(),
                  sim::AgentConfig{}, WaypointTargetConfig{});
  ASSERT_EQ(node.targets.size(), 2u);
  EXPECT_EQ(node.targets[0].node, 1);  // b, not c
  EXPECT_EQ(node.targets[0].heading_bin, 0);
  EXPECT_EQ(node.targets[0].distance_bin, 7);
  EXPECT_EQ(node.targets[1].node, 3);  // d
  EXPECT_EQ(node.targets[1].heading_bin, 30);
  EXPECT_EQ(node.targets[1].distance_bin, 5);
  EXPECT_TRUE(node.kept);
  EXPECT_NEAR(node.heatmap[0 * kNumDistances + 7], 1.0f, 1e-6f);

  // facing +X the same neighbours sit at other bins: b is 90 degrees left
  const NodeTargets turned =
      nodeTargets(graph, transferred, 0, -kPi / 2.0f, scene_->navmesh(),
                  sim::AgentConfig{}, WaypointTargetConfig{});
  ASSERT_EQ(turned.targets.size(), 2u);
  EXPECT_EQ(turned.targets[0].heading_bin, 30);
  EXPECT_EQ(turned.targets[1].heading_bin, 60);

  // a node whose only target is behind the cube is dropped
  data::NavGraph blocked;
  blocked.addNode("a", a + up);
  blocked.addNode("x", a + up + Vec3f(3.0f, 0.0f, 0.0f));
  blocked.addEdge("a", "x");
  // x stands 3 m to the right, in the cube's shadow (the cube is 2.5 m away)
  std::vector<data::NodeTransferResult> both(2);
  both[0] = {true, a, 0.0f, 0};
  both[1] = {true, a + Vec3f(3.0f, 0.0f, 0.0f), 0.0f, 0};
  const NodeTargets dropped =
      nodeTargets(blocked, both, 0, 0.0f, scene_->navmesh(), sim::AgentConfig{},
                  WaypointTargetConfig{});
  ASSERT_EQ(dropped.targets.size(), 1u);
  EXPECT_EQ(dropped.targets[0].heading_bin, 90);
  EXPECT_FALSE(dropped.kept);

  // an invalid node has no targets
  try {
    nodeTargets(graph, transferred, 5, 0.0f, scene_->navmesh(),
                sim::AgentConfig{}, WaypointTargetConfig{});
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("node 'f' was not transferred"));
  }
}

}  // namespace
}  // namespace vln::waypoint
