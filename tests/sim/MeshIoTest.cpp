#include "sim/MeshIo.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <filesystem>
#include <string>
#include <tuple>
#include <vector>

#include "sim/SceneFileFixtures.h"
#include "sim/SceneSemanticsFile.h"
#include "support/TestPaths.h"

namespace vln::sim {
namespace {

namespace fs = std::filesystem;
using test::checkerTexture;
using test::expectThrowWith;
using test::featureMesh;
using test::featureSemantics;

// A triangle with everything attached to its corners, in a form that can be
// sorted: exporters may reorder and duplicate vertices, so round trips are
// compared as sorted triangle sets.
struct Corner {
  std::array<float, 3> position{};
  Rgb8 color{255, 255, 255};
  std::array<float, 2> uv{};
};
struct FlatTriangle {
  std::array<Corner, 3> corners;
  int object = -1;
  // the material itself, not its index (indices may be renumbered)
  std::string material;
  bool operator<(const FlatTriangle& o) const {
    return std::tie(object, material, corners[0].position, corners[1].position,
                    corners[2].position) <
           std::tie(o.object, o.material, o.corners[0].position,
                    o.corners[1].position, o.corners[2].position);
  }
};

std::vector<FlatTriangle> flatten(const TriangleMesh& mesh) {
  std::vector<FlatTriangle> out;
  for (size_t t = 0; t < mesh.triangleCount(); ++t) {
    FlatTriangle tri;
    for (int k = 0; k < 3; ++k) {
      const uint32_t v = mesh.indices[3 * t + k];
      Corner& c = tri.corners[k];
      c.position = {mesh.positions[v].x(), mesh.positions[v].y(),
                    mesh.positions[v].z()};
      if (!mesh.colors.empty()) c.color = mesh.colors[v];
      if (!mesh.uvs.empty()) c.uv = {mesh.uvs[v].x(), mesh.uvs[v].y()};
    }
    // start each triangle at its smallest corner, keeping the winding
    const auto first = std::min_element(tri.corners.begin(), tri.corners.end(),
                                        [](const Corner& a, const Corner& b) {
                                          return a.position < b.position;
                                        });
    std::rotate(tri.corners.begin(), first, tri.corners.end());
    if (!mesh.triangle_object.empty()) tri.object = mesh.triangle_object[t];
    const int m =
        mesh.triangle_material.empty() ? -1 : mesh.triangle_material[t];
    if (m >= 0) {
      const Material& material = mesh.materials[m];
      tri.material =
          strCat(material.name, "|", material.base_color[0], ",",
                 material.base_color[1], ",", material.base_color[2], "|",
                 material.texture < 0 ? std::string("-")
                                      : mesh.textures[material.texture].name);
    }
    out.push_back(tri);
  }
  std::sort(out.begin(), out.end());
  return out;
}

void expectSameTriangles(const TriangleMesh& expected,
                         const TriangleMesh& actual) {
  const auto a = flatten(expected);
  const auto b = flatten(actual);
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].object, b[i].object) << "triangle " << i;
    EXPECT_EQ(a[i].material, b[i].material) << "triangle " << i;
    for (int k = 0; k < 3; ++k) {
      for (int d = 0; d < 3; ++d)
        EXPECT_NEAR(a[i].corners[k].position[d], b[i].corners[k].position[d],
                    1e-5)
            << "triangle " << i << " corner " << k;
      EXPECT_EQ(a[i].corners[k].color, b[i].corners[k].color)
          << "triangle " << i << " corner " << k;
      for (int d = 0; d < 2; ++d)
        EXPECT_NEAR(a[i].corners[k].uv[d], b[i].corners[k].uv[d], 1e-5)
            << "triangle " << i << " corner " << k;
    }
  }
}

// ---------------------------------------------------------------------------
// round trips
// ---------------------------------------------------------------------------

class RoundTripTest : public ::testing::TestWithParam<std::string> {};

TEST_P(RoundTripTest, KeepsTrianglesColoursUvsMaterialsTexturesAndObjects) {
  test::TempDir dir;
  const fs::path file = dir / ("scene" + GetParam());
  const TriangleMesh mesh = featureMesh();
  const SceneSemantics semantics = featureSemantics();
  saveScene(file, mesh, semantics);
  ASSERT_TRUE(fs::exists(semanticsPath(file)));

  const LoadedScene loaded = loadScene(file, MeshLoadConfig{});
  expectSameTriangles(mesh, loaded.mesh);
  EXPECT_EQ(loaded.mesh.materials, mesh.materials);
  EXPECT_EQ(loaded.mesh.textures, mesh.textures);
  EXPECT_EQ(loaded.semantics, semantics);
}

TEST_P(RoundTripTest, MeshWithoutOptionalArraysStaysWithout) {
  test::TempDir dir;
  const fs::path file = dir / ("bare" + GetParam());
  TriangleMesh mesh;
  mesh.positions = {{0, 0, 0}, {1, 0, 0}, {0, 0, -1}};
  mesh.indices = {0, 1, 2};
  saveScene(file, mesh);
  EXPECT_FALSE(fs::exists(semanticsPath(file)));
  const LoadedScene loaded = loadScene(file, MeshLoadConfig{});
  expectSameTriangles(mesh, loaded.mesh);
  EXPECT_TRUE(loaded.mesh.colors.empty());
  EXPECT_TRUE(loaded.mesh.uvs.empty());
  EXPECT_TRUE(loaded.mesh.triangle_material.empty());
  EXPECT_TRUE(loaded.mesh.triangle_object.empty());
  EXPECT_TRUE(loaded.mesh.materials.empty());
}

TEST_P(RoundTripTest, MaterialsComeBackInOrderOfFirstUse) {
  test::TempDir dir;
  const fs::path file = dir / ("order" + GetParam());
  TriangleMesh mesh;
  mesh.positions = {{0, 0, 0}, {1, 0, 0}, {0, 0, -1}, {2, 0, 0}};
  mesh.indices = {0, 1, 2, 1, 3, 2};
  mesh.materials = {{"unused", {1, 0, 0}, -1},
                    {"second", {0, 1, 0}, -1},
                    {"first", {0, 0, 1}, 0}};
  mesh.textures = {checkerTexture("only")};
  mesh.triangle_material = {2, 1};
  mesh.triangle_object = {4, 5};
  saveScene(file, mesh);
  const LoadedScene loaded = loadScene(file, MeshLoadConfig{});
  expectSameTriangles(mesh, loaded.mesh);
  ASSERT_EQ(loaded.mesh.materials.size(), 2u);
  EXPECT_EQ(loaded.mesh.materials[0].name, "first");
  EXPECT_EQ(loaded.mesh.materials[0].texture, 0);
  EXPECT_EQ(loaded.mesh.materials[1].name, "second");
  EXPECT_EQ(loaded.mesh.textures, mesh.textures);
}

INSTANTIATE_TEST_SUITE_P(Formats, RoundTripTest,
                         ::testing::Values(".glb", ".obj"),
                         [](const auto& info) { return info.param.substr(1); });

TEST(MeshIoTest, TexturedQuadKeepsTexelsAndOrientation) {
  // a quad whose uv (0, 0) corner must show the texture's first row
  TriangleMesh quad;
  quad.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  quad.uvs = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  quad.indices = {0, 1, 2, 0, 2, 3};
  quad.materials = {{"picture", {1, 1, 1}, 0}};
  quad.triangle_material = {0, 0};
  quad.textures = {checkerTexture("photo")};
  test::TempDir dir;
  for (const char* ext : {".glb", ".obj"}) {
    const fs::path file = dir / (std::string("quad") + ext);
    saveScene(file, quad);
    const LoadedScene loaded = loadScene(file, MeshLoadConfig{});
    ASSERT_EQ(loaded.mesh.textures.size(), 1u) << ext;
    EXPECT_EQ(loaded.mesh.textures[0], quad.textures[0]) << ext;
    ASSERT_EQ(loaded.mesh.materials.size(), 1u) << ext;
    EXPECT_EQ(loaded.mesh.materials[0].texture, 0) << ext;
    // the vertex at the world origin keeps uv (0, 0)
    for (size_t v = 0; v < loaded.mesh.positions.size(); ++v) {
      if (loaded.mesh.positions[v].isZero()) {
        EXPECT_TRUE(loaded.mesh.uvs[v].isZero(1e-6f)) << ext;
      }
    }
  }
  // the .obj wrote its texture beside it, named after the scene
  EXPECT_TRUE(fs::exists(dir / "quad_photo.png"));
  EXPECT_TRUE(fs::exists(dir / "quad.mtl"));
}

TEST(MeshIoTest, SavingWithoutSemanticsRemovesAStaleSidecar) {
  test::TempDir dir;
  const fs::path file = dir / "scene.glb";
  saveScene(file, featureMesh(), featureSemantics());
  ASSERT_TRUE(fs::exists(semanticsPath(file)));
  saveScene(file, featureMesh());
  EXPECT_FALSE(fs::exists(semanticsPath(file)));
}

TEST(MeshIoTest, UnsupportedExportExtension) {
  test::TempDir dir;
  expectThrowWith<std::invalid_argument>(
      [&] { saveScene(dir / "scene.fbx", featureMesh()); },
      {"scene.fbx", "unsupported extension"});
}

TEST(MeshIoTest, InvalidMeshIsNotWritten) {
  test::TempDir dir;
  TriangleMesh mesh = featureMesh();
  mesh.indices.push_back(999);
  mesh.indices.push_back(0);
  mesh.indices.push_back(1);
  expectThrowWith<std::invalid_argument>(
      [&] { saveScene(dir / "bad.glb", mesh); }, {"bad.glb"});
  EXPECT_FALSE(fs::exists(dir / "bad.glb"));
}

}  // namespace
}  // namespace vln::sim
