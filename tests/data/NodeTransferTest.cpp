#include "data/NodeTransfer.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <memory>

#include "sim/Agent.h"
#include "sim/Mesh.h"
#include "sim/NavMesh.h"

namespace vln::data {
namespace {

// ---------------------------------------------------------------------------
// hand-made geometry (world frame, +Y up, metres)
// ---------------------------------------------------------------------------

void addQuad(sim::TriangleMesh& mesh, const Vec3f& a, const Vec3f& b,
             const Vec3f& c, const Vec3f& d) {
  // a, b, c, d counter-clockwise seen from the side the quad faces
  const auto base = static_cast<uint32_t>(mesh.positions.size());
  for (const Vec3f& p : {a, b, c, d}) mesh.positions.push_back(p);
  for (uint32_t i : {0u, 1u, 2u, 0u, 2u, 3u}) mesh.indices.push_back(base + i);
}

// An upward-facing floor rectangle [x0, x1] x [z0, z1] at height y.
void addFloor(sim::TriangleMesh& mesh, float x0, float z0, float x1, float z1,
              float y = 0.0f) {
  addQuad(mesh, {x0, y, z1}, {x1, y, z1}, {x1, y, z0}, {x0, y, z0});
}

// A closed axis-aligned box (all six faces facing out).
void addBox(sim::TriangleMesh& mesh, const Vec3f& lo, const Vec3f& hi) {
  const float x0 = lo.x(), y0 = lo.y(), z0 = lo.z();
  const float x1 = hi.x(), y1 = hi.y(), z1 = hi.z();
  addQuad(mesh, {x0, y1, z1}, {x1, y1, z1}, {x1, y1, z0}, {x0, y1, z0});  // +y
  addQuad(mesh, {x0, y0, z0}, {x1, y0, z0}, {x1, y0, z1}, {x0, y0, z1});  // -y
  addQuad(mesh, {x1, y0, z1}, {x1, y0, z0}, {x1, y1, z0}, {x1, y1, z1});  // +x
  addQuad(mesh, {x0, y0, z0}, {x0, y0, z1}, {x0, y1, z1}, {x0, y1, z0});  // -x
  addQuad(mesh, {x0, y0, z1}, {x1, y0, z1}, {x1, y1, z1}, {x0, y1, z1});  // +z
  addQuad(mesh, {x1, y0, z0}, {x0, y0, z0}, {x0, y1, z0}, {x1, y1, z0});  // -z
}

std::unique_ptr<sim::NavMesh> buildNavMesh(const sim::TriangleMesh& mesh) {
  return sim::NavMesh::build(mesh, sim::NavMeshConfig{});
}

// A 10 x 10 m room with a 2.0 x 1.2 m table (top at 0.75 m) centred at
// (5, 5): the table top is large enough to become its own navmesh island.
sim::TriangleMesh roomWithTable() {
  sim::TriangleMesh mesh;
  addFloor(mesh, 0, 0, 10, 10);
  addBox(mesh, {4.0f, 0.0f, 4.4f}, {6.0f, 0.75f, 5.6f});
  return mesh;
}

// A 10 x 10 m floor with square holes of side 0.6 m centred at (3, 5) and
// side 1.6 m centred at (7, 5).
sim::TriangleMesh floorWithHoles() {
  sim::TriangleMesh mesh;
  // strips around the holes: below z=4.2, above z=5.8, and between/around
  addFloor(mesh, 0, 0, 10, 4.2f);
  addFloor(mesh, 0, 5.8f, 10, 10);
  addFloor(mesh, 0, 4.2f, 2.7f, 5.8f);
  addFloor(mesh, 3.3f, 4.2f, 6.2f, 5.8f);
  addFloor(mesh, 7.8f, 4.2f, 10, 5.8f);
  addFloor(mesh, 2.7f, 4.2f, 3.3f, 4.7f);
  addFloor(mesh, 2.7f, 5.3f, 3.3f, 5.8f);
  return mesh;
}

TransferConfig defaultTransfer() { return TransferConfig{}; }

// ---------------------------------------------------------------------------
// node transfer
// ---------------------------------------------------------------------------

TEST(NodeTransferTest, FloorNodeLandsDirectlyBelow) {
  const auto navmesh = buildNavMesh(roomWithTable());
  const auto floors = floorIslands(*navmesh, 4.0f);
  const Vec3f node(2.0f, 1.4f, 2.5f);
  const auto r = transferNode(*navmesh, node, defaultTransfer(), floors);
  ASSERT_TRUE(r.valid);
  EXPECT_LT(r.displacement, 1e-3f);
  EXPECT_NEAR(r.waypoint.y(), 0.0f, 0.25f);
  EXPECT_EQ(r.island, 0);
}

TEST(NodeTransferTest, TableTopIsAnIslandButNotAFloor) {
  const auto navmesh = buildNavMesh(roomWithTable());
  const int tableIsland = navmesh->islandIndex({5.0f, 0.75f, 5.0f});
  ASSERT_GT(tableIsland, 0) << "the table top should be a separate island";
  const auto floors = floorIslands(*navmesh, 4.0f);
  EXPECT_TRUE(floors[0]);
  EXPECT_FALSE(floors[static_cast<size_t>(tableIsland)]);
}

TEST(NodeTransferTest, NodeOverTableEdgeMovesToTheFloorWithMinimalShift) {
  const auto navmesh = buildNavMesh(roomWithTable());
  const auto floors = floorIslands(*navmesh, 4.0f);
  // 0.15 m inside the table's +z edge (z = 5.6): straight down is the table
  // top, the nearest floor is just beyond the edge plus the agent radius
  const Vec3f node(5.0f, 1.9f, 5.45f);
  const auto r = transferNode(*navmesh, node, defaultTransfer(), floors);
  ASSERT_TRUE(r.valid);
  EXPECT_EQ(r.island, 0);
  EXPECT_NEAR(r.waypoint.y(), 0.0f, 0.25f);
  EXPECT_GT(r.waypoint.z(), 5.6f);
  // minimal: edge at 5.6 plus agent radius 0.1 and a voxel of rounding
  EXPECT_GT(r.displacement, 0.15f);
  EXPECT_LT(r.displacement, 0.15f + 0.1f + 0.12f);
  EXPECT_NEAR(r.waypoint.x(), 5.0f, 0.05f) << "moved sideways, not outward";
}

TEST(NodeTransferTest, NodeOverTableCentreIsRejected) {
  const auto navmesh = buildNavMesh(roomWithTable());
  const auto floors = floorIslands(*navmesh, 4.0f);
  // 0.6 m from the nearest edge: no floor within 0.5 m
  const auto r =
      transferNode(*navmesh, {5.0f, 1.9f, 5.0f}, defaultTransfer(), floors);
  EXPECT_FALSE(r.valid);
  // a ground agent would accept it if table tops were floors: the island
  // rule is what rejects it
  const std::vector<bool> everything(floors.size(), true);
  const auto onTable =
      transferNode(*navmesh, {5.0f, 1.9f, 5.0f}, defaultTransfer(), everything);
  ASSERT_TRUE(onTable.valid);
  EXPECT_NEAR(onTable.waypoint.y(), 0.75f, 0.25f);
}

TEST(NodeTransferTest, SmallHoleIsBridgedLargeHoleIsRejected) {
  const auto navmesh = buildNavMesh(floorWithHoles());
  const auto floors = floorIslands(*navmesh, 4.0f);
  const auto small =
      transferNode(*navmesh, {3.0f, 1.3f, 5.0f}, defaultTransfer(), floors);
  ASSERT_TRUE(small.valid);
  // half the hole plus the agent radius, give or take a voxel
  EXPECT_GT(small.displacement, 0.3f);
  EXPECT_LT(small.displacement, 0.5f);
  const auto large =
      transferNode(*navmesh, {7.0f, 1.3f, 5.0f}, defaultTransfer(), floors);
  EXPECT_FALSE(large.valid);
}

TEST(NodeTransferTest, ShortRayDoesNotReachTheFloor) {
  const auto navmesh = buildNavMesh(roomWithTable());
  const auto floors = floorIslands(*navmesh, 4.0f);
  TransferConfig config = defaultTransfer();
  config.cast_distance = 0.5f;
  const auto r = transferNode(*navmesh, {2.0f, 1.4f, 2.5f}, config, floors);
  EXPECT_FALSE(r.valid);
}

TEST(NodeTransferTest, StatisticsCountAdjustedNodes) {
  TransferStats stats;
  std::vector<NodeTransferResult> results(4);
  results[0] = {true, Vec3f::Zero(), 0.0f, 0};
  results[1] = {true, Vec3f::Zero(), 0.3f, 0};
  results[2] = {true, Vec3f::Zero(), 0.1f, 0};
  results[3] = {false, Vec3f::Zero(), 0.0f, -1};
  stats.addNodes(results, defaultTransfer());
  EXPECT_EQ(stats.nodes, 4);
  EXPECT_EQ(stats.nodes_valid, 3);
  EXPECT_EQ(stats.nodes_adjusted, 2);
  EXPECT_DOUBLE_EQ(stats.nodeTransferRate(), 0.75);
  EXPECT_NEAR(stats.meanAdjustedDisplacement(), 0.2, 1e-6);
  EXPECT_NEAR(stats.adjustedShare(), 2.0 / 3.0, 1e-9);
  EXPECT_THAT(stats.report(), ::testing::HasSubstr("paper 98.3%"));
}

// ---------------------------------------------------------------------------
// navigability and ground truth
// ---------------------------------------------------------------------------

// Two 4 x 4 rooms side by side along x, split by a wall at x in [4, 4.2]
// with one opening of `gap` metres centred at z = `at`.
sim::TriangleMesh twoRooms(float gap, float at = 2.0f) {
  sim::TriangleMesh mesh;
  addFloor(mesh, 0, 0, 8.2f, 4);
  const float z0 = at - gap / 2.0f;
  const float z1 = at + gap / 2.0f;
  if (z0 > 0.0f) addBox(mesh, {4.0f, 0.0f, 0.0f}, {4.2f, 2.5f, z0});
  if (z1 < 4.0f) addBox(mesh, {4.0f, 0.0f, z1}, {4.2f, 2.5f, 4.0f});
  return mesh;
}

TEST(NodeTransferTest, NarrowWallGapIsNotNavigable) {
  const auto navmesh = buildNavMesh(twoRooms(/*gap=*/0.15f));
  const std::vector<Vec3f> waypoints = {
      {1.0f, 0.0f, 2.0f}, {3.0f, 0.0f, 2.0f}, {6.0f, 0.0f, 2.0f}};
  std::vector<Vec3f> snapped;
  for (const Vec3f& w : waypoints) snapped.push_back(*navmesh->snapPoint(w));
  const auto r = checkNavigability(*navmesh, sim::AgentConfig{},
                                   defaultTransfer(), snapped, 0.0f);
  EXPECT_FALSE(r.navigable());
  EXPECT_EQ(r.failure, NavigabilityFailure::kNoPath);
  EXPECT_EQ(r.failed_index, 1);
  EXPECT_TRUE(r.ground_truth.actions.empty());
}

TEST(NodeTransferTest, DoorwayIsNavigableAndGroundTruthReplays) {
  const auto navmesh = buildNavMesh(twoRooms(/*gap=*/1.0f));
  const std::vector<Vec3f> raw = {{1.0f, 0.0f, 1.0f},
                                  {3.0f, 0.0f, 3.0f},
                                  {5.5f, 0.0f, 2.5f},
                                  {7.0f, 0.0f, 0.8f}};
  std::vector<Vec3f> waypoints;
  for (const Vec3f& w : raw) waypoints.push_back(*navmesh->snapPoint(w));
  const float startHeading = 2.0f;
  const sim::AgentConfig agent;
  const auto r = checkNavigability(*navmesh, agent, defaultTransfer(),
                                   waypoints, startHeading);
  ASSERT_TRUE(r.navigable()) << navigabilityFailureName(r.failure);
  const GroundTruthPath& gt = r.ground_truth;
  ASSERT_FALSE(gt.actions.empty());
  EXPECT_EQ(gt.actions.back(), sim::Action::kStop);
  EXPECT_EQ(
      std::count(gt.actions.begin(), gt.actions.end(), sim::Action::kStop), 1);
  EXPECT_EQ(gt.locations.size(), static_cast<size_t>(gt.forward_steps) + 1);
  EXPECT_EQ(gt.locations.front(), waypoints.front());
  EXPECT_TRUE(std::isfinite(r.geodesic_distance));
  EXPECT_GT(r.geodesic_distance,
            (waypoints.back() - waypoints.front()).norm() - 1e-3f);

  // replaying the actions passes within 0.5 m of every waypoint in order,
  // reproduces every recorded location and ends within 3 m of the goal
  sim::AgentState state{waypoints.front(), startHeading};
  size_t next = 1;
  size_t location = 1;
  for (const sim::Action action : gt.actions) {
    const Vec3f before = state.position;
    sim::applyAction(*navmesh, agent, state, action);
    if (state.position != before) {
      ASSERT_LT(location, gt.locations.size());
      EXPECT_LT((state.position - gt.locations[location]).norm(), 1e-5f);
      ++location;
    }
    while (next < waypoints.size() &&
           navmesh->geodesicDistance(state.position, waypoints[next]) <= 0.5f)
      ++next;
  }
  EXPECT_EQ(location, gt.locations.size());
  EXPECT_EQ(next, waypoints.size()) << "waypoint " << next << " never reached";
  EXPECT_LE(navmesh->geodesicDistance(state.position, waypoints.back()), 0.5f);
  EXPECT_LE(navmesh->geodesicDistance(state.position, waypoints.back()), 3.0f);
}

TEST(NodeTransferTest, InvalidNodeFailsTheTrajectory) {
  const auto navmesh = buildNavMesh(twoRooms(/*gap=*/1.0f));
  std::vector<NodeTransferResult> transferred(3);
  transferred[0] = {true, *navmesh->snapPoint({1, 0, 1}), 0.0f, 0};
  transferred[1] = {false, Vec3f::Zero(), 0.0f, -1};
  transferred[2] = {true, *navmesh->snapPoint({3, 0, 3}), 0.0f, 0};
  const auto r =
      checkNavigability(*navmesh, sim::AgentConfig{}, defaultTransfer(),
                        transferred, {0, 1, 2}, 0.0f);
  EXPECT_EQ(r.failure, NavigabilityFailure::kInvalidNode);
  EXPECT_EQ(r.failed_index, 1);
  TransferStats stats;
  stats.addTrajectory(r);
  EXPECT_EQ(stats.failed_invalid_node, 1);
  EXPECT_DOUBLE_EQ(stats.navigableRate(), 0.0);
}

TEST(NodeTransferTest, LongDetourAroundAWallIsRejectedUnlessDisabled) {
  // the only opening is at the far end (z = 3.4): a leg straight through
  // the wall near z = 0.5 is 1.4 m long but about 6.5 m to walk
  const auto navmesh = buildNavMesh(twoRooms(/*gap=*/1.0f, /*at=*/3.4f));
  const std::vector<Vec3f> waypoints = {*navmesh->snapPoint({1.5f, 0, 0.5f}),
                                        *navmesh->snapPoint({3.4f, 0, 0.5f}),
                                        *navmesh->snapPoint({4.8f, 0, 0.5f})};
  const float straight = (waypoints[2] - waypoints[1]).norm();
  const float around = navmesh->geodesicDistance(waypoints[1], waypoints[2]);
  ASSERT_GT(around, 2.0f * std::max(straight, 1.0f));
  const auto r = checkNavigability(*navmesh, sim::AgentConfig{},
                                   defaultTransfer(), waypoints, 0.0f);
  EXPECT_EQ(r.failure, NavigabilityFailure::kDetour);
  EXPECT_EQ(r.failed_index, 1);
  TransferStats stats;
  stats.addTrajectory(r);
  EXPECT_EQ(stats.failed_detour, 1);

  // the paper has no such check: with it disabled the walk around counts
  TransferConfig paper = defaultTransfer();
  paper.max_leg_detour = 0.0f;
  const auto walked =
      checkNavigability(*navmesh, sim::AgentConfig{}, paper, waypoints, 0.0f);
  EXPECT_TRUE(walked.navigable()) << navigabilityFailureName(walked.failure);
  EXPECT_GT(0.25f * walked.ground_truth.forward_steps, around - 0.6f);
}

TEST(NodeTransferTest, StepCapRejectsUnreachableInTime) {
  const auto navmesh = buildNavMesh(twoRooms(/*gap=*/1.0f));
  TransferConfig config = defaultTransfer();
  config.leg_base_steps = 3;
  config.leg_steps_per_meter = 0.0f;
  const std::vector<Vec3f> waypoints = {*navmesh->snapPoint({1, 0, 1}),
                                        *navmesh->snapPoint({7, 0, 3})};
  const auto r =
      checkNavigability(*navmesh, sim::AgentConfig{}, config, waypoints, 0.0f);
  EXPECT_EQ(r.failure, NavigabilityFailure::kNotReached);
  EXPECT_EQ(r.failed_index, 0);
}

}  // namespace
}  // namespace vln::data
