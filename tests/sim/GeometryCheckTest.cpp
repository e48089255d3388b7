#include "sim/GeometryCheck.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "sim/SimTestScenes.h"

namespace vln::sim {
namespace {

using test::addBox;
using test::roomWithTable;
using test::slabWithFurniture;
using ::testing::HasSubstr;
using ::testing::IsEmpty;

// What a Z-up file holds for a Y-up world mesh: world (x, y, z) is stored
// as (x, -z, y), which importing with up_axis z maps back.
TriangleMesh asZUpFile(TriangleMesh mesh) {
  for (Vec3f& p : mesh.positions) p = Vec3f(p.x(), -p.z(), p.y());
  return mesh;
}

// The message of the std::invalid_argument that `body` throws.
template <class F>
std::string invalidArgument(F&& body) {
  try {
    body();
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  ADD_FAILURE() << "expected std::invalid_argument";
  return "";
}

TriangleMesh oneTriangle(const Vec3f& a, const Vec3f& b, const Vec3f& c) {
  TriangleMesh mesh;
  mesh.positions = {a, b, c};
  mesh.indices = {0, 1, 2};
  return mesh;
}

// ---------------------------------------------------------------------------
// checkSceneGeometry
// ---------------------------------------------------------------------------

TEST(GeometryCheckTest, AnOrdinaryRoomPasses) {
  EXPECT_NO_THROW(checkSceneGeometry(roomWithTable(), "room"));
}

TEST(GeometryCheckTest, MoreTrianglesThanTheLimitAreRefused) {
  // the limit is a parameter so that a 2-box mesh can exceed it
  TriangleMesh mesh;
  addBox(mesh, {0, 0, 0}, {1, 1, 1});
  addBox(mesh, {2, 0, 0}, {3, 1, 1});
  GeometryLimits limits;
  limits.max_triangles = 20;
  const std::string message =
      invalidArgument([&] { checkSceneGeometry(mesh, "two boxes", limits); });
  EXPECT_THAT(message, HasSubstr("two boxes"));
  EXPECT_THAT(message, HasSubstr("24 triangles, more than the limit of 20"));
  limits.max_triangles = 24;
  EXPECT_NO_THROW(checkSceneGeometry(mesh, "two boxes", limits));
  EXPECT_EQ(GeometryLimits{}.max_triangles, kMaxSceneTriangles);
}

TEST(GeometryCheckTest, HugeAndNonFiniteCoordinatesAreRefused) {
  const std::string huge = invalidArgument([] {
    checkSceneGeometry(oneTriangle({0, 0, 0}, {1e30f, 0, 0}, {0, 0, 1}), "far");
  });
  EXPECT_THAT(huge, HasSubstr("vertex 1"));
  EXPECT_THAT(huge, HasSubstr("beyond +-1e+06 m"));
  EXPECT_THAT(huge, HasSubstr("sim.mesh.scale"));
  for (float bad : {std::numeric_limits<float>::quiet_NaN(),
                    std::numeric_limits<float>::infinity()}) {
    EXPECT_THAT(invalidArgument([&] {
                  checkSceneGeometry(
                      oneTriangle({0, 0, 0}, {1, 0, 0}, {0, bad, 1}), "nan");
                }),
                HasSubstr("vertex 2 has a non-finite coordinate"));
  }
  // 1e6 itself is allowed
  EXPECT_NO_THROW(checkSceneGeometry(
      oneTriangle({-1e6f, 0, 0}, {1e6f, 0, 0}, {0, 0, 1e6f}), "wide"));
}

TEST(GeometryCheckTest, OnlyDegenerateTrianglesAreRefused) {
  // a repeated corner, three collinear corners, and a triangle whose area
  // underflows in single precision
  TriangleMesh mesh = oneTriangle({0, 0, 0}, {1, 0, 0}, {0, 0, 0});
  mesh.positions.insert(mesh.positions.end(),
                        {Vec3f(0, 0, 0), Vec3f(1, 1, 1), Vec3f(2, 2, 2)});
  mesh.indices.insert(mesh.indices.end(), {3, 4, 5});
  EXPECT_THAT(invalidArgument([&] { checkSceneGeometry(mesh, "flat"); }),
              HasSubstr("all 2 triangles are degenerate"));
  const std::string tiny = invalidArgument([] {
    checkSceneGeometry(oneTriangle({0, 0, 0}, {1e-30f, 0, 0}, {0, 0, 1e-30f}),
                       "tiny");
  });
  EXPECT_THAT(tiny, HasSubstr("zero area in single precision"));
  // one good triangle among degenerate ones is enough
  mesh.positions.insert(mesh.positions.end(),
                        {Vec3f(0, 0, 0), Vec3f(1, 0, 0), Vec3f(0, 0, 1)});
  mesh.indices.insert(mesh.indices.end(), {6, 7, 8});
  EXPECT_NO_THROW(checkSceneGeometry(mesh, "one good"));
}

// ---------------------------------------------------------------------------
// upAxisHint
// ---------------------------------------------------------------------------

TEST(GeometryCheckTest, AZUpRoomReadYUpGetsTheHint) {
  MeshLoadConfig yUp;
  const std::string hint = upAxisHint(asZUpFile(roomWithTable()), yUp);
  EXPECT_THAT(hint, HasSubstr("looks Z-up"));
  EXPECT_THAT(hint, HasSubstr("sim.mesh.up_axis: z"));
  EXPECT_THAT(hint, HasSubstr("--up-axis z"));
}

TEST(GeometryCheckTest, RoomsReadWithTheirOwnUpAxisGetNoHint) {
  MeshLoadConfig yUp;
  EXPECT_THAT(upAxisHint(roomWithTable(), yUp), IsEmpty());
  // the loader maps a Z-up file's (x, y, z) to (x, z, -y): what it returns
  // for asZUpFile() is the Y-up room again
  MeshLoadConfig zUp;
  zUp.up_axis = UpAxis::kZ;
  EXPECT_THAT(upAxisHint(roomWithTable(), zUp), IsEmpty());
}

// Below a floor slab's top there are only faces pointing down, so the
// floor must be looked for above the lowest up-facing triangle, not the
// lowest vertex (the slab room got no hint).
TEST(GeometryCheckTest, AZUpSlabWithLowFurnitureGetsTheHint) {
  MeshLoadConfig yUp;
  EXPECT_THAT(upAxisHint(asZUpFile(slabWithFurniture()), yUp),
              HasSubstr("looks Z-up"));
  EXPECT_THAT(upAxisHint(slabWithFurniture(), yUp), IsEmpty());
}

TEST(GeometryCheckTest, AYUpRoomReadZUpGetsTheHint) {
  // a Y-up file read Z-up: its floor ends up facing world -Z
  TriangleMesh read = roomWithTable();
  for (Vec3f& p : read.positions) p = Vec3f(p.x(), p.z(), -p.y());
  MeshLoadConfig zUp;
  zUp.up_axis = UpAxis::kZ;
  const std::string hint = upAxisHint(read, zUp);
  EXPECT_THAT(hint, HasSubstr("looks Y-up"));
  EXPECT_THAT(hint, HasSubstr("--up-axis y"));
}

// ---------------------------------------------------------------------------
// positions
// ---------------------------------------------------------------------------

TEST(GeometryCheckTest, PositionsMustBeFiniteAndNearTheScene) {
  const Eigen::AlignedBox3f scene(Vec3f(0, 0, 0), Vec3f(6, 3, 6));
  const Eigen::AlignedBox3f accepted = poseBounds(scene);
  EXPECT_EQ(accepted.min(), Vec3f::Constant(-kPoseMargin));
  EXPECT_NO_THROW(checkPosition("f()", "p", Vec3f(3, 1, 3), accepted));
  EXPECT_NO_THROW(checkPosition("f()", "p", Vec3f(-99, 0, 105), accepted));
  const std::string far = invalidArgument(
      [&] { checkPosition("f()", "eye", Vec3f(1e30f, 0, 0), accepted); });
  EXPECT_THAT(far, HasSubstr("f(): eye (1e+30"));
  EXPECT_THAT(far, HasSubstr("outside the scene"));
  EXPECT_THAT(invalidArgument([&] {
                checkPosition("f()", "eye", Vec3f(0, NAN, 0), accepted);
              }),
              HasSubstr("must be finite"));
}

}  // namespace
}  // namespace vln::sim
