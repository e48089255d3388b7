// Tests src/sim/MeshSubdivision.cpp: piece counts, surface and winding
// kept, attributes interpolated and inherited, on a two-triangle quad.

#include "sim/MeshSubdivision.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <stdexcept>

namespace vln::sim {
namespace {

using ::testing::HasSubstr;
using ::testing::ThrowsMessage;

// A 2 x 1 m quad in the floor plane (two triangles facing +Y) with colours,
// uvs, two materials and two object ids.
TriangleMesh coloredQuad() {
  TriangleMesh mesh;
  mesh.positions = {{0, 0, 0}, {0, 0, -1}, {2, 0, -1}, {2, 0, 0}};
  mesh.colors = {{0, 0, 0}, {90, 0, 30}, {180, 60, 0}, {0, 120, 240}};
  mesh.uvs = {{0, 0}, {0, 1}, {2, 1}, {2, 0}};
  mesh.indices = {0, 3, 2, 0, 2, 1};
  mesh.materials = {{"floor", {1, 1, 1}, -1}, {"rug", {0.5f, 0.5f, 0.5f}, -1}};
  mesh.triangle_material = {0, 1};
  mesh.triangle_object = {-1, 7};
  return mesh;
}

float area(const TriangleMesh& mesh, size_t t) {
  const Vec3f& a = mesh.positions[mesh.indices[3 * t]];
  const Vec3f& b = mesh.positions[mesh.indices[3 * t + 1]];
  const Vec3f& c = mesh.positions[mesh.indices[3 * t + 2]];
  return 0.5f * (b - a).cross(c - a).norm();
}

Vec3f normal(const TriangleMesh& mesh, size_t t) {
  const Vec3f& a = mesh.positions[mesh.indices[3 * t]];
  const Vec3f& b = mesh.positions[mesh.indices[3 * t + 1]];
  const Vec3f& c = mesh.positions[mesh.indices[3 * t + 2]];
  return (b - a).cross(c - a).normalized();
}

TEST(MeshSubdivisionTest, OneKeepsTheTriangles) {
  const TriangleMesh quad = coloredQuad();
  const TriangleMesh same = subdivide(quad, 1);
  same.validate("subdivide(quad, 1)");
  ASSERT_EQ(same.triangleCount(), 2u);
  EXPECT_EQ(same.positions.size(), 6u);  // vertices are not shared
  for (size_t t = 0; t < 2; ++t) {
    for (int k = 0; k < 3; ++k) {
      const uint32_t from = quad.indices[3 * t + k];
      const uint32_t to = same.indices[3 * t + k];
      EXPECT_EQ(same.positions[to], quad.positions[from]);
      EXPECT_EQ(same.colors[to], quad.colors[from]);
      EXPECT_EQ(same.uvs[to], quad.uvs[from]);
    }
  }
  EXPECT_EQ(same.triangle_material, quad.triangle_material);
  EXPECT_EQ(same.triangle_object, quad.triangle_object);
  EXPECT_EQ(same.materials, quad.materials);
}

TEST(MeshSubdivisionTest, PiecesCoverTheSameSurfaceWithTheSameWinding) {
  const TriangleMesh quad = coloredQuad();
  const int n = 4;
  const TriangleMesh dense = subdivide(quad, n);
  dense.validate("subdivide(quad, 4)");
  ASSERT_EQ(dense.triangleCount(), 2u * n * n);
  // (n + 1)(n + 2) / 2 grid vertices per parent triangle
  EXPECT_EQ(dense.positions.size(), 2u * 15u);
  // every piece of a parent has 1/n^2 of its area and faces +Y
  for (size_t t = 0; t < dense.triangleCount(); ++t) {
    EXPECT_NEAR(area(dense, t), area(quad, t / (n * n)) / (n * n), 1e-6f)
        << "piece " << t;
    EXPECT_TRUE(normal(dense, t).isApprox(Vec3f::UnitY())) << "piece " << t;
  }
  // vertices stay on the quad
  for (const Vec3f& p : dense.positions) {
    EXPECT_EQ(p.y(), 0.0f);
    EXPECT_GE(p.x(), 0.0f);
    EXPECT_LE(p.x(), 2.0f);
    EXPECT_GE(p.z(), -1.0f);
    EXPECT_LE(p.z(), 0.0f);
  }
}

TEST(MeshSubdivisionTest, AttributesAreInterpolatedAndInherited) {
  const TriangleMesh quad = coloredQuad();
  const TriangleMesh dense = subdivide(quad, 2);
  ASSERT_EQ(dense.colors.size(), dense.positions.size());
  ASSERT_EQ(dense.uvs.size(), dense.positions.size());
  // first parent 0-3-2: grid vertex 1 is the midpoint of corners 0 and 2
  // (barycentric (0, 1/2)), grid vertex 2 is corner 2
  EXPECT_EQ(dense.positions[1], Vec3f(1, 0, -0.5f));
  EXPECT_EQ(dense.colors[1], (Rgb8{90, 30, 0}));
  EXPECT_TRUE(dense.uvs[1].isApprox(Vec2f(1, 0.5f)));
  EXPECT_EQ(dense.positions[2], quad.positions[2]);
  EXPECT_EQ(dense.colors[2], quad.colors[2]);
  // the pieces of parent t carry its material and object
  EXPECT_THAT(dense.triangle_material,
              ::testing::ElementsAre(0, 0, 0, 0, 1, 1, 1, 1));
  EXPECT_THAT(dense.triangle_object,
              ::testing::ElementsAre(-1, -1, -1, -1, 7, 7, 7, 7));
  EXPECT_EQ(dense.materials, quad.materials);
}

TEST(MeshSubdivisionTest, ColourlessMeshStaysColourless) {
  TriangleMesh bare;
  bare.positions = {{0, 0, 0}, {1, 0, 0}, {0, 0, -1}};
  bare.indices = {0, 1, 2};
  const TriangleMesh dense = subdivide(bare, 3);
  EXPECT_EQ(dense.triangleCount(), 9u);
  EXPECT_TRUE(dense.colors.empty());
  EXPECT_TRUE(dense.uvs.empty());
  EXPECT_TRUE(dense.triangle_material.empty());
  EXPECT_TRUE(dense.triangle_object.empty());
}

TEST(MeshSubdivisionTest, RejectsLessThanOnePiece) {
  EXPECT_THAT([] { subdivide(coloredQuad(), 0); },
              ThrowsMessage<std::invalid_argument>(
                  HasSubstr("subdivide(): n must be >= 1, got 0")));
}

}  // namespace
}  // namespace vln::sim
