#include "sim/NavMesh.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <random>
#include <thread>
#include <vector>

#include "common/FileIo.h"
#include "sim/GeometryCheck.h"
#include "sim/SimTestScenes.h"
#include "support/TestPaths.h"

namespace vln::sim {
namespace {

using ::testing::HasSubstr;
using test::addBox;
using test::kSlab;
using test::kTableHi;
using test::kTableLo;
using test::kTableTop;
using test::kWall;
using test::kWallTop;
using test::roomWithTable;

// ---------------------------------------------------------------------------
// inline geometry
// ---------------------------------------------------------------------------

// An L-shaped corridor with 1.2 m wide legs: leg 1 spans x in [0, 6],
// z in [0, 1.2]; leg 2 spans x in [4.8, 6], z in [0, 6]. The inner (reflex)
// corner of the free space is at (4.8, 1.2). Walls surround it.
TriangleMesh lCorridor() {
  TriangleMesh m;
  addBox(m, {0, -kSlab, 0}, {6, 0, 1.2f});
  addBox(m, {4.8f, -kSlab, 1.2f}, {6, 0, 6});
  addBox(m, {-kWall, -kSlab, -kWall}, {6 + kWall, kWallTop, 0});     // south
  addBox(m, {6, -kSlab, -kWall}, {6 + kWall, kWallTop, 6 + kWall});  // east
  addBox(m, {-kWall, -kSlab, 1.2f},
         {4.8f, kWallTop, 1.2f + kWall});  // leg 1 north
  addBox(m, {4.8f - kWall, -kSlab, 1.2f},
         {4.8f, kWallTop, 6 + kWall});  // leg 2 west
  addBox(m, {-kWall, -kSlab, -kWall},
         {0, kWallTop, 1.2f + kWall});  // leg 1 end
  addBox(m, {4.8f - kWall, -kSlab, 6},
         {6 + kWall, kWallTop, 6 + kWall});  // leg 2 end
  return m;
}

// Recast erodes by ceil(agent_radius / cell_size) cells measured from the
// first blocked cell, so a wall face that falls inside a cell moves the
// navmesh edge between agent_radius and agent_radius + cell_size away from
// it: the middle of that range is the expected inset.
float expectedInset(const NavMeshConfig& c) {
  return c.agent_radius + c.cell_size / 2.0f;
}

// Recast rounds span tops up to the next cell_height and contour corners take
// the highest neighbouring span, so navmesh heights lie between the true
// surface height and two cell heights above it.
void expectNavmeshHeight(float y, float surface) {
  EXPECT_GE(y, surface - 1e-3f);
  EXPECT_LE(y, surface + 2.0f * NavMeshConfig{}.cell_height);
}

class NavMeshTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    corridor_ = NavMesh::build(lCorridor(), NavMeshConfig{}).release();
    room_ = NavMesh::build(roomWithTable(), NavMeshConfig{}).release();
  }
  static void TearDownTestSuite() {
    delete corridor_;
    delete room_;
    corridor_ = room_ = nullptr;
  }
  static const NavMesh& corridor() { return *corridor_; }
  static const NavMesh& room() { return *room_; }

 private:
  static NavMesh* corridor_;
  static NavMesh* room_;
};
NavMesh* NavMeshTest::corridor_ = nullptr;
NavMesh* NavMeshTest::room_ = nullptr;

// ---------------------------------------------------------------------------
// geodesic distances in the L corridor
// ---------------------------------------------------------------------------

TEST_F(NavMeshTest, StraightCorridorDistanceIsEuclidean) {
  // both points in leg 1, on the same line: no corner in between
  const Vec3f a(0.8f, 0.0f, 0.6f), b(4.0f, 0.0f, 0.6f);
  EXPECT_NEAR(corridor().geodesicDistance(a, b), 3.2f, 1e-4f);
  EXPECT_NEAR(corridor().geodesicDistance(b, a), 3.2f, 1e-4f);
  const auto path = corridor().shortestPath(a, b);
  ASSERT_EQ(path.size(), 2u);
  EXPECT_NEAR(path.front().x(), a.x(), 1e-5f);
  EXPECT_NEAR(path.back().z(), b.z(), 1e-5f);
}

TEST_F(NavMeshTest, CornerDistanceMatchesAnalyticPath) {
  // leg 1 to leg 2: the straight line is blocked, the path bends around the
  // reflex corner (4.8, 1.2). The agent's centre stays `inset` away from the
  // walls, so analytically the path is A -> K -> B with K the corner of the
  // shrunk free space.
  const NavMeshConfig c;
  const Vec2f a2(1.0f, 0.6f), b2(5.4f, 5.0f);
  const float inset = expectedInset(c);
  const Vec2f k(4.8f + inset, 1.2f - inset);
  const float expected = (k - a2).norm() + (b2 - k).norm();
  // Recast may move that corner by half a cell per axis (where the wall
  // falls inside a voxel) plus edge_max_error cells (contour
  // simplification); a corner moved by s changes the length by at most
  // |grad_K| * s with grad_K = unit(K - A) + unit(K - B).
  const float shift = c.cell_size * (std::sqrt(2.0f) / 2.0f + c.edge_max_error);
  const float gradient = ((k - a2).normalized() + (k - b2).normalized()).norm();
  const float tolerance = gradient * shift;  // 0.12 m for the defaults

  const Vec3f a(a2.x(), 0.0f, a2.y()), b(b2.x(), 0.0f, b2.y());
  const float d = corridor().geodesicDistance(a, b);
  EXPECT_NEAR(d, expected, tolerance);
  // the tolerance still tells the agent radius apart: a point agent (corner
  // at (4.8, 1.2)) would be further off
  const Vec2f bare(4.8f, 1.2f);
  EXPECT_GT(std::abs(d - ((bare - a2).norm() + (b2 - bare).norm())), tolerance);
  EXPECT_NEAR(corridor().geodesicDistance(b, a), d, 1e-4f);

  // the path turns at the corner: an interior corner near (4.8, 1.2)
  const auto path = corridor().shortestPath(a, b);
  ASSERT_GE(path.size(), 3u);
  for (size_t i = 1; i + 1 < path.size(); ++i) {
    EXPECT_NEAR(path[i].x(), 4.8f, 0.25f);
    EXPECT_NEAR(path[i].z(), 1.2f, 0.25f);
  }
  float length = 0.0f;
  for (size_t i = 1; i < path.size(); ++i)
    length += (path[i] - path[i - 1]).norm();
  EXPECT_NEAR(length, d, 1e-4f);
}

TEST_F(NavMeshTest, SamePointHasZeroDistance) {
  const Vec3f a(2.0f, 0.0f, 0.6f);
  EXPECT_EQ(corridor().geodesicDistance(a, a), 0.0f);
}

TEST_F(NavMeshTest, PointsFarFromTheNavmeshAreUnreachable) {
  const Vec3f a(1.0f, 0.0f, 0.6f);
  EXPECT_EQ(corridor().geodesicDistance(a, {30.0f, 0.0f, 30.0f}), kUnreachable);
  EXPECT_EQ(corridor().geodesicDistance({30.0f, 0.0f, 30.0f}, a), kUnreachable);
  EXPECT_TRUE(corridor().shortestPath(a, {30.0f, 0.0f, 30.0f}).empty());
}

// ---------------------------------------------------------------------------
// islands: the table top is its own island
// ---------------------------------------------------------------------------

TEST_F(NavMeshTest, TableTopIsASeparateIsland) {
  const Vec3f floorPoint(1.0f, 0.0f, 1.0f);
  const Vec3f tablePoint(3.0f, kTableTop, 3.0f);
  ASSERT_TRUE(room().isNavigable(floorPoint));
  ASSERT_TRUE(room().isNavigable(tablePoint));
  EXPECT_EQ(room().islandCount(), 2);
  EXPECT_EQ(room().islandIndex(floorPoint), 0);  // largest island
  EXPECT_EQ(room().islandIndex(tablePoint), 1);
  EXPECT_EQ(room().geodesicDistance(floorPoint, tablePoint), kUnreachable);
  EXPECT_TRUE(room().shortestPath(floorPoint, tablePoint).empty());
  EXPECT_EQ(room().islandIndex({30.0f, 0.0f, 30.0f}), -1);
}

TEST_F(NavMeshTest, IslandAreasMatchTheFloorPlan) {
  // floor: the room minus the table, both shrunk/grown by the inset (0.1 to
  // 0.15 m); 0.1 m inset gives 5.8^2 - 1.7^2 = 30.75 m^2, 0.15 m gives
  // 5.7^2 - 1.8^2 = 29.25 m^2
  EXPECT_GT(room().islandArea(0), 29.0f);
  EXPECT_LT(room().islandArea(0), 31.0f);
  // table top: the ledge filter drops the rim cell, erosion two more, so
  // 0.1 to 0.2 m comes off each side: 1.1^2 = 1.21 to 1.3^2 = 1.69 m^2
  EXPECT_GT(room().islandArea(1), 1.1f);
  EXPECT_LT(room().islandArea(1), 1.75f);
  EXPECT_NEAR(room().navigableArea(),
              room().islandArea(0) + room().islandArea(1), 1e-3f);
  EXPECT_GT(room().polygonCount(), 2);
  EXPECT_THROW(room().islandArea(2), std::invalid_argument);

  // triangles() covers exactly the navigable area
  float area = 0.0f;
  for (const auto& t : room().triangles()) {
    const Vec3f n = (t[1] - t[0]).cross(t[2] - t[0]);
    EXPECT_GE(n.y(), 0.0f);  // faces up
    area += 0.5f * n.norm();
  }
  EXPECT_NEAR(area, room().navigableArea(), 1e-2f);
}

// ---------------------------------------------------------------------------
// snapping and navigability
// ---------------------------------------------------------------------------

TEST_F(NavMeshTest, SnapPointProjectsOntoTheSurface) {
  // from above: same x, z; y on the floor
  const auto snapped = room().snapPoint({1.0f, 1.0f, 1.0f});
  ASSERT_TRUE(snapped.has_value());
  EXPECT_NEAR(snapped->x(), 1.0f, 1e-5f);
  EXPECT_NEAR(snapped->z(), 1.0f, 1e-5f);
  expectNavmeshHeight(snapped->y(), 0.0f);

  // from inside a wall: onto the navmesh edge, one inset from the wall face
  const auto edge = room().snapPoint({-0.06f, 0.0f, 1.0f});
  ASSERT_TRUE(edge.has_value());
  EXPECT_NEAR(edge->x(), expectedInset(NavMeshConfig{}), 0.03f);
  EXPECT_NEAR(edge->z(), 1.0f, 1e-4f);

  // nothing within the search box
  EXPECT_FALSE(room().snapPoint({30.0f, 0.0f, 30.0f}).has_value());
  EXPECT_FALSE(
      room().snapPoint({1.0f, 5.0f, 1.0f}, {0.5f, 1.0f, 0.5f}).has_value());
}

TEST_F(NavMeshTest, IsNavigableOnAndOffTheMesh) {
  EXPECT_TRUE(room().isNavigable({1.0f, 0.0f, 1.0f}));
  EXPECT_TRUE(room().isNavigable({1.0f, 0.3f, 1.0f}));   // within maxYDelta
  EXPECT_FALSE(room().isNavigable({1.0f, 1.0f, 1.0f}));  // too high above
  EXPECT_FALSE(room().isNavigable({1.0f, 0.3f, 1.0f}, /*maxYDelta=*/0.05f));
  EXPECT_FALSE(room().isNavigable({0.04f, 0.0f, 1.0f}));   // inside the inset
  EXPECT_FALSE(room().isNavigable({-0.06f, 0.0f, 1.0f}));  // inside a wall
  EXPECT_FALSE(room().isNavigable({3.0f, 0.0f, 3.0f}));    // under the table
  EXPECT_FALSE(room().isNavigable({30.0f, 0.0f, 30.0f}));
}

TEST_F(NavMeshTest, DistanceToObstacleIsDistanceToTheNavmeshEdge) {
  // 1 m from the west wall and > 1.25 m from anything else
  EXPECT_NEAR(room().distanceToObstacle({1.0f, 0.0f, 1.5f}),
              1.0f - expectedInset(NavMeshConfig{}), 0.03f);
  // the search radius caps the answer
  EXPECT_NEAR(room().distanceToObstacle({1.0f, 0.0f, 1.5f}, /*maxRadius=*/0.5f),
              0.5f, 1e-5f);
  EXPECT_EQ(room().distanceToObstacle({30.0f, 0.0f, 30.0f}), 0.0f);
}

// ---------------------------------------------------------------------------
// moving over the surface
// ---------------------------------------------------------------------------

TEST_F(NavMeshTest, MoveAlongSurfaceInTheOpenReachesTheTarget) {
  const Vec3f from = *room().snapPoint({1.0f, 0.0f, 1.0f});
  const Vec3f to = from + Vec3f(0.2f, 0.0f, 0.1f);
  const Vec3f reached = room().moveAlongSurface(from, to);
  EXPECT_NEAR(reached.x(), to.x(), 1e-5f);
  EXPECT_NEAR(reached.z(), to.z(), 1e-5f);
  EXPECT_NEAR(reached.y(), from.y(), 1e-4f);
  EXPECT_EQ(room().moveNoSliding(from, to), reached);
}

TEST_F(NavMeshTest, MoveIntoAWallStopsAtTheEdge) {
  const Vec3f from = *room().snapPoint({0.4f, 0.0f, 1.0f});
  const Vec3f into = from + Vec3f(-1.0f, 0.0f, 0.0f);
  const Vec3f reached = room().moveAlongSurface(from, into);
  EXPECT_NEAR(reached.x(), expectedInset(NavMeshConfig{}), 0.03f);
  EXPECT_NEAR(reached.z(), 1.0f, 1e-4f);
  EXPECT_TRUE(room().isNavigable(reached));
  EXPECT_EQ(room().moveNoSliding(from, into), from);
}

// ---------------------------------------------------------------------------
// random points
// ---------------------------------------------------------------------------

TEST_F(NavMeshTest, RandomPointsAreNavigableAndReproducible) {
  std::mt19937_64 a(7), b(7);
  int onTable = 0;
  constexpr int kSamples = 2000;
  for (int i = 0; i < kSamples; ++i) {
    const Vec3f p = room().randomPoint(a);
    EXPECT_EQ(p, room().randomPoint(b));
    ASSERT_TRUE(room().isNavigable(p)) << p.transpose();
    onTable += room().islandIndex(p) == 1 ? 1 : 0;
  }
  // area-weighted: the table's share of samples matches its share of area
  // within 4 binomial standard deviations
  const double share = room().islandArea(1) / room().navigableArea();
  const double sigma = std::sqrt(share * (1 - share) / kSamples);
  EXPECT_NEAR(onTable / double(kSamples), share, 4 * sigma);
}

TEST_F(NavMeshTest, RandomPointsOnAnIslandStayOnIt) {
  std::mt19937_64 rng(3);
  for (int i = 0; i < 200; ++i) {
    const Vec3f p = room().randomPoint(rng, /*island=*/1);
    EXPECT_EQ(room().islandIndex(p), 1);
    EXPECT_GT(p.x(), kTableLo);
    EXPECT_LT(p.x(), kTableHi);
    expectNavmeshHeight(p.y(), kTableTop);
  }
  EXPECT_THROW(room().randomPoint(rng, 2), std::invalid_argument);
  EXPECT_THROW(room().randomPoint(rng, -2), std::invalid_argument);
}

TEST(NavMeshUniformity, RandomPointsCoverAnOpenFloorEvenly) {
  // one 4 x 4 m slab: quadrant counts are uniform (chi-square, 3 dof,
  // 99.9% quantile 16.27)
  TriangleMesh slab;
  addBox(slab, {0, -kSlab, 0}, {4, 0, 4});
  const auto nav = NavMesh::build(slab, NavMeshConfig{});
  std::mt19937_64 rng(11);
  int counts[4] = {0, 0, 0, 0};
  constexpr int kSamples = 4000;
  for (int i = 0; i < kSamples; ++i) {
    const Vec3f p = nav->randomPoint(rng);
    ++counts[(p.x() > 2.0f ? 1 : 0) + (p.z() > 2.0f ? 2 : 0)];
  }
  double chi2 = 0.0;
  for (int c : counts)
    chi2 += std::pow(c - kSamples / 4.0, 2) / (kSamples / 4.0);
  EXPECT_LT(chi2, 16.27);
}

// ---------------------------------------------------------------------------
// build failures
// ---------------------------------------------------------------------------

TEST(NavMeshBuild, NothingWalkableThrows) {
  // a lone vertical wall: no upward-facing surface survives
  TriangleMesh wall;
  addBox(wall, {0, 0, 0}, {4, 2.5f, 0.1f});
  try {
    NavMesh::build(wall, NavMeshConfig{});
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("no walkable surface"));
  }
}

TEST(NavMeshBuild, EmptyMeshAndBadConfigThrow) {
  EXPECT_THROW(NavMesh::build(TriangleMesh{}, NavMeshConfig{}),
               std::invalid_argument);
  TriangleMesh slab;
  addBox(slab, {0, -kSlab, 0}, {4, 0, 4});
  NavMeshConfig bad;
  bad.cell_size = -1.0f;
  try {
    NavMesh::build(slab, bad);
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("cell_size"));
  }
}

// Hostile geometry (issue 19): each is a clear std::invalid_argument before
// Recast sees the mesh, or a navmesh, never a crash.

// The message of the std::invalid_argument NavMesh::build() throws.
std::string buildError(const TriangleMesh& mesh,
                       const NavMeshConfig& config = {}) {
  try {
    NavMesh::build(mesh, config);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  ADD_FAILURE() << "expected std::invalid_argument";
  return "";
}

// A quad with the given corners (two triangles).
TriangleMesh quad(const Vec3f& a, const Vec3f& b, const Vec3f& c,
                  const Vec3f& d) {
  TriangleMesh m;
  m.positions = {a, b, c, d};
  m.indices = {0, 1, 2, 0, 2, 3};
  return m;
}

TEST(NavMeshBuild, AMeshFlatAlongXOrZIsAClearError) {
  // a Z-up floor read Y-up stands on edge: 0 m deep in world z (Recast
  // wrote outside its heightfield on this, a SIGSEGV)
  const std::string flatZ =
      buildError(quad({-10, -10, 0}, {10, -10, 0}, {10, 10, 0}, {-10, 10, 0}));
  EXPECT_THAT(flatZ, HasSubstr("flat along world z"));
  EXPECT_THAT(flatZ, HasSubstr("Z-up"));
  const std::string flatX =
      buildError(quad({0, 0, 0}, {0, 0, 5}, {0, 5, 5}, {0, 5, 0}));
  EXPECT_THAT(flatX, HasSubstr("flat along world x"));
  // thinner than half a cell is flat too
  EXPECT_THAT(
      buildError(quad({0, 0, 0}, {5, 0, 0}, {5, 5, 0.02f}, {0, 5, 0.02f})),
      HasSubstr("flat along world z"));
}

TEST(NavMeshBuild, AFloorWithNoHeightIsWalkable) {
  // zero extent along y is an ordinary flat floor
  const auto navmesh = NavMesh::build(
      quad({0, 0, 0}, {0, 0, 10}, {10, 0, 10}, {10, 0, 0}), NavMeshConfig{});
  EXPECT_EQ(navmesh->islandCount(), 1);
  // eroded by agent_radius plus up to a cell on every side
  EXPECT_NEAR(navmesh->navigableArea(), 9.75f * 9.75f, 2.0f);
}

TEST(NavMeshBuild, ASingleTriangleIsAFloorOrAClearError) {
  TriangleMesh big;
  big.positions = {{0, 0, 0}, {0, 0, 10}, {10, 0, 0}};
  big.indices = {0, 1, 2};
  const auto navmesh = NavMesh::build(big, NavMeshConfig{});
  EXPECT_GT(navmesh->navigableArea(), 30.0f);
  EXPECT_LT(navmesh->navigableArea(), 50.0f);
  // one 10 cm triangle leaves nothing after erosion
  TriangleMesh small = big;
  for (Vec3f& p : small.positions) p *= 0.01f;
  EXPECT_THAT(buildError(small), HasSubstr("no walkable surface"));
}

TEST(NavMeshBuild, OnlyVerticalTrianglesLeaveAnEmptyHeightfield) {
  // nothing faces up: no walkable span at all
  TriangleMesh walls;
  for (float x : {0.0f, 2.0f, 4.0f})
    walls.append(quad({x, 0, 0}, {x, 0, 4}, {x, 3, 4}, {x, 3, 0}));
  EXPECT_THAT(buildError(walls), HasSubstr("no walkable surface"));
}

TEST(NavMeshBuild, DegenerateHugeAndTinyMeshesAreRefused) {
  // collinear and repeated corners only
  TriangleMesh degenerate;
  degenerate.positions = {{0, 0, 0}, {1, 0, 1}, {2, 0, 2}, {5, 0, 0}};
  degenerate.indices = {0, 1, 2, 3, 3, 0};
  EXPECT_THAT(buildError(degenerate), HasSubstr("degenerate"));
  // a vertex at 1e30 m
  TriangleMesh far = quad({0, 0, 0}, {0, 0, 10}, {10, 0, 10}, {10, 0, 0});
  far.positions[2] = {1e30f, 0, 10};
  EXPECT_THAT(buildError(far), HasSubstr("beyond +-1e+06 m"));
  // coordinates at 1e-30 m: every area underflows
  TriangleMesh tiny = quad({0, 0, 0}, {0, 0, 1}, {1, 0, 1}, {1, 0, 0});
  for (Vec3f& p : tiny.positions) p *= 1e-30f;
  EXPECT_THAT(buildError(tiny), HasSubstr("degenerate"));
  // 1e-7 m: triangles, but less than one cell across
  TriangleMesh small = quad({0, 0, 0}, {0, 0, 1}, {1, 0, 1}, {1, 0, 0});
  for (Vec3f& p : small.positions) p *= 1e-7f;
  EXPECT_THAT(buildError(small), HasSubstr("less than one cell"));
}

TEST(NavMeshBuild, GridsBeyondRecastsLimitsAreRefused) {
  // 600 km x 600 km: more than 1e8 cells (and no float-to-int overflow on
  // the way)
  EXPECT_THAT(buildError(quad({-3e5f, 0, -3e5f}, {-3e5f, 0, 3e5f},
                              {3e5f, 0, 3e5f}, {3e5f, 0, -3e5f})),
              HasSubstr("check the mesh scale"));
  // a 4 km long, 1 m wide corridor: 80,000 cells along x, more than one
  // tile holds
  EXPECT_THAT(
      buildError(quad({0, 0, 0}, {0, 0, 1}, {4000, 0, 1}, {4000, 0, 0})),
      HasSubstr("at most 65535 cells"));
}

TEST_F(NavMeshTest, QueriesOutsideTheSceneAreRefused) {
  // the corridor spans x, z in [-0.12, 6.12]; 100 m beyond is accepted
  const NavMesh& navmesh = corridor();
  EXPECT_NEAR(navmesh.bounds().min().x(), -kWall, 1e-6f);
  EXPECT_NEAR(navmesh.bounds().max().z(), 6 + kWall, 1e-6f);
  EXPECT_EQ(navmesh.queryBounds().min(),
            navmesh.bounds().min() - Vec3f::Constant(kPoseMargin));
  const Vec3f on(1.0f, 0.0f, 0.6f);
  const Vec3f near(80.0f, 0.0f, 80.0f);
  EXPECT_EQ(navmesh.geodesicDistance(on, near), kUnreachable);
  for (const Vec3f& bad : {Vec3f(1e30f, 0, 0), Vec3f(200, 0, 0),
                           Vec3f(NAN, 0, 0), Vec3f(0, -INFINITY, 0)}) {
    SCOPED_TRACE(bad.transpose());
    EXPECT_THAT([&] { navmesh.geodesicDistance(on, bad); },
                ::testing::ThrowsMessage<std::invalid_argument>(
                    HasSubstr("NavMesh::geodesicDistance(): to")));
    EXPECT_THROW(navmesh.shortestPath(bad, on), std::invalid_argument);
    EXPECT_THROW(navmesh.moveAlongSurface(on, bad), std::invalid_argument);
    EXPECT_THROW(navmesh.moveNoSliding(bad, on), std::invalid_argument);
    EXPECT_THROW(navmesh.snapPoint(bad), std::invalid_argument);
    EXPECT_THROW(navmesh.isNavigable(bad), std::invalid_argument);
    EXPECT_THROW(navmesh.islandIndex(bad), std::invalid_argument);
    EXPECT_THROW(navmesh.distanceToObstacle(bad), std::invalid_argument);
  }
  EXPECT_THROW(navmesh.snapPoint(on, Vec3f(NAN, 1, 1)), std::invalid_argument);
  EXPECT_THROW(navmesh.snapPoint(on, Vec3f(1e30f, 1, 1)),
               std::invalid_argument);
  EXPECT_THROW(navmesh.snapPoint(on, Vec3f(-1, 1, 1)), std::invalid_argument);
  EXPECT_THROW(navmesh.distanceToObstacle(on, NAN), std::invalid_argument);
  EXPECT_THROW(navmesh.distanceToObstacle(on, -1.0f), std::invalid_argument);
}

TEST(NavMeshBuild, SteepRampIsNotWalkableButAGentleOneIs) {
  // a 4 m long ramp rising 1 m (14 degrees) joins two floors; at 60
  // degrees it would exceed agent_max_slope = 45
  TriangleMesh m;
  addBox(m, {0, -kSlab, 0}, {3, 0, 2});
  addBox(m, {7, 1.0f - kSlab, 0}, {10, 1.0f, 2});
  const auto base = static_cast<uint32_t>(m.positions.size());
  m.positions.insert(m.positions.end(),
                     {{3, 0, 0}, {7, 1, 0}, {7, 1, 2}, {3, 0, 2}});
  m.indices.insert(m.indices.end(),
                   {base, base + 3, base + 2, base, base + 2, base + 1});
  const auto nav = NavMesh::build(m, NavMeshConfig{});
  const Vec3f low(1.5f, 0.0f, 1.0f), high(8.5f, 1.0f, 1.0f);
  EXPECT_EQ(nav->islandIndex(low), nav->islandIndex(high));
  // Detour string-pulls in the horizontal plane, so a path that never turns
  // sideways keeps only its end points and its length is their 3-D distance
  // (as in Habitat): sqrt(7^2 + 1^2); end heights are exact to within a
  // fraction of cell_height, which changes the length by < 0.02 m
  EXPECT_NEAR(nav->geodesicDistance(low, high), std::sqrt(50.0f), 0.02f);

  NavMeshConfig flatOnly;
  flatOnly.agent_max_slope = 10.0f;
  const auto flat = NavMesh::build(m, flatOnly);
  EXPECT_EQ(flat->geodesicDistance(low, high), kUnreachable);
}

// ---------------------------------------------------------------------------
// thread safety
// ---------------------------------------------------------------------------

TEST_F(NavMeshTest, ConcurrentQueriesMatchSerialOnes) {
  std::mt19937_64 rng(17);
  std::vector<std::pair<Vec3f, Vec3f>> pairs;
  for (int i = 0; i < 300; ++i)
    pairs.emplace_back(corridor().randomPoint(rng),
                       corridor().randomPoint(rng));
  std::vector<float> serial;
  for (const auto& [p, q] : pairs)
    serial.push_back(corridor().geodesicDistance(p, q));

  constexpr int kThreads = 4;
  std::vector<std::vector<float>> results(kThreads);
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t) {
    threads.emplace_back([&, t] {
      // each thread walks the pairs in a different order (strides coprime
      // to 300) so that the same queries run at different times
      constexpr size_t kStrides[kThreads] = {1, 7, 11, 13};
      auto& out = results[static_cast<size_t>(t)];
      out.resize(pairs.size());
      for (size_t k = 0; k < pairs.size(); ++k) {
        const size_t i = (k * kStrides[t]) % pairs.size();
        out[i] = corridor().geodesicDistance(pairs[i].first, pairs[i].second);
        static_cast<void>(
            corridor().moveAlongSurface(pairs[i].first, pairs[i].second));
      }
    });
  }
  for (auto& thread : threads) thread.join();
  for (const auto& out : results) EXPECT_EQ(out, serial);
  // every pair is on the corridor's single island
  for (float d : serial) EXPECT_TRUE(std::isfinite(d));
}

}  // namespace
}  // namespace vln::sim
