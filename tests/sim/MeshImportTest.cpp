// Tests of the importer (MeshImport.cpp) and its input guards, through its
// entry point loadScene().

#include "sim/MeshImport.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "sim/MeshIo.h"
#include "sim/SceneFileFixtures.h"
#include "support/TestPaths.h"

namespace vln::sim {
namespace {

using test::expectThrowWith;

constexpr const char* kUnitCubeObj = R"(# unit cube, 8 vertices, 6 quads
v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0
v 0 0 1
v 1 0 1
v 1 1 1
v 0 1 1
f 1 4 3 2
f 5 6 7 8
f 1 2 6 5
f 4 8 7 3
f 1 5 8 4
f 2 3 7 6
)";

// ---------------------------------------------------------------------------
// import
// ---------------------------------------------------------------------------

TEST(MeshImportTest, LoadsObjUnitCube) {
  test::TempDir dir;
  const auto file = test::writeText(dir / "cube.obj", kUnitCubeObj);
  const LoadedScene scene = loadScene(file, MeshLoadConfig{});
  EXPECT_EQ(scene.mesh.triangleCount(), 12u);
  EXPECT_EQ(scene.mesh.positions.size(), 8u);  // identical vertices joined
  const auto box = scene.mesh.bounds();
  EXPECT_TRUE(box.min().isApprox(Vec3f(0, 0, 0)));
  EXPECT_TRUE(box.max().isApprox(Vec3f(1, 1, 1)));
  EXPECT_TRUE(scene.semantics.empty());
  EXPECT_TRUE(scene.mesh.triangle_object.empty());
  // total area of a unit cube is 6
  double area = 0.0;
  for (size_t t = 0; t < scene.mesh.triangleCount(); ++t) {
    const Vec3f& a = scene.mesh.positions[scene.mesh.indices[3 * t]];
    const Vec3f& b = scene.mesh.positions[scene.mesh.indices[3 * t + 1]];
    const Vec3f& c = scene.mesh.positions[scene.mesh.indices[3 * t + 2]];
    area += 0.5 * (b - a).cross(c - a).norm();
  }
  EXPECT_NEAR(area, 6.0, 1e-5);
}

TEST(MeshImportTest, ZUpFilesAreRotatedAndScaled) {
  test::TempDir dir;
  const auto file =
      test::writeText(dir / "tri.obj", "v 1 2 3\nv 4 5 6\nv 7 8 10\nf 1 2 3\n");
  MeshLoadConfig config;
  config.up_axis = UpAxis::kZ;
  config.scale = 0.5f;
  const LoadedScene scene = loadScene(file, config);
  ASSERT_EQ(scene.mesh.triangleCount(), 1u);
  // file (x, y, z) -> world (x, z, -y) * scale
  const std::vector<Vec3f> expected = {
      {0.5f, 1.5f, -1.0f}, {2.0f, 3.0f, -2.5f}, {3.5f, 5.0f, -4.0f}};
  for (int k = 0; k < 3; ++k)
    EXPECT_TRUE(
        scene.mesh.positions[scene.mesh.indices[k]].isApprox(expected[k]))
        << "corner " << k;

  config.up_axis = UpAxis::kY;
  config.scale = 2.0f;
  const LoadedScene yUp = loadScene(file, config);
  EXPECT_TRUE(
      yUp.mesh.positions[yUp.mesh.indices[2]].isApprox(Vec3f(14, 16, 20)));
}

TEST(MeshImportTest, LoadsPlyLShapedFloorWithVertexColours) {
  // an L-shaped floor in the z = 0 plane of a Z-up scan: three unit squares
  constexpr const char* kPly = R"(ply
format ascii 1.0
element vertex 8
property float x
property float y
property float z
property uchar red
property uchar green
property uchar blue
element face 3
property list uchar int vertex_indices
end_header
0 0 0 255 0 0
1 0 0 0 255 0
2 0 0 0 0 255
0 1 0 10 20 30
1 1 0 40 50 60
2 1 0 70 80 90
0 2 0 100 110 120
1 2 0 130 140 150
4 0 1 4 3
4 1 2 5 4
4 3 4 7 6
)";
  test::TempDir dir;
  const auto file = test::writeText(dir / "floor.ply", kPly);
  MeshLoadConfig config;
  config.up_axis = UpAxis::kZ;
  const LoadedScene scene = loadScene(file, config);
  EXPECT_EQ(scene.mesh.triangleCount(), 6u);
  ASSERT_EQ(scene.mesh.colors.size(), scene.mesh.positions.size());
  // every vertex lies on the world floor (y = 0) and keeps its exact colour
  std::map<std::pair<float, float>, Rgb8> colorAt;
  for (size_t v = 0; v < scene.mesh.positions.size(); ++v) {
    EXPECT_FLOAT_EQ(scene.mesh.positions[v].y(), 0.0f);
    colorAt[{scene.mesh.positions[v].x(), scene.mesh.positions[v].z()}] =
        scene.mesh.colors[v];
  }
  // file (1, 2, 0) -> world (1, 0, -2)
  EXPECT_EQ((colorAt[{1.0f, -2.0f}]), (Rgb8{130, 140, 150}));
  EXPECT_EQ((colorAt[{2.0f, 0.0f}]), (Rgb8{0, 0, 255}));
  // every face points up in the world after the Z-up conversion
  for (size_t t = 0; t < scene.mesh.triangleCount(); ++t) {
    const Vec3f& a = scene.mesh.positions[scene.mesh.indices[3 * t]];
    const Vec3f& b = scene.mesh.positions[scene.mesh.indices[3 * t + 1]];
    const Vec3f& c = scene.mesh.positions[scene.mesh.indices[3 * t + 2]];
    EXPECT_GT((b - a).cross(c - a).y(), 0.0f) << "triangle " << t;
  }
}

TEST(MeshImportTest, DropsPointsLinesAndDegenerateTriangles) {
  test::TempDir dir;
  const auto file = test::writeText(dir / "mixed.obj",
                                    "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 5 5 5\n"
                                    "f 1 2 3\n"
                                    "f 1 1 2\n"
                                    "l 1 4\n"
                                    "p 4\n");
  const LoadedScene scene = loadScene(file, MeshLoadConfig{});
  EXPECT_EQ(scene.mesh.triangleCount(), 1u);
  scene.mesh.validate("mixed.obj");
}

// A .gltf with a node hierarchy: the parent translates, the child (named
// object_7) scales. The buffer is an inline base64 data URI.
std::string base64(const std::string& bytes) {
  static const char* kAlphabet =
      "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  size_t i = 0;
  for (; i + 2 < bytes.size(); i += 3) {
    const uint32_t n = (uint8_t(bytes[i]) << 16) |
                       (uint8_t(bytes[i + 1]) << 8) | uint8_t(bytes[i + 2]);
    for (int s = 18; s >= 0; s -= 6) out.push_back(kAlphabet[(n >> s) & 63]);
  }
  if (i < bytes.size()) {
    uint32_t n = uint8_t(bytes[i]) << 16;
    if (i + 1 < bytes.size()) n |= uint8_t(bytes[i + 1]) << 8;
    out.push_back(kAlphabet[(n >> 18) & 63]);
    out.push_back(kAlphabet[(n >> 12) & 63]);
    out.push_back(i + 1 < bytes.size() ? kAlphabet[(n >> 6) & 63] : '=');
    out.push_back('=');
  }
  return out;
}

TEST(MeshImportTest, AppliesNodeTransformsAndObjectNames) {
  const float positions[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  const uint32_t indices[3] = {0, 1, 2};
  std::string buffer(reinterpret_cast<const char*>(positions),
                     sizeof(positions));
  buffer.append(reinterpret_cast<const char*>(indices), sizeof(indices));
  const std::string gltf = R"({
  "asset": {"version": "2.0"},
  "scene": 0,
  "scenes": [{"nodes": [0, 2]}],
  "nodes": [
    {"name": "furniture", "translation": [10, 0, 0], "children": [1]},
    {"name": "object_7", "scale": [2, 2, 2], "mesh": 0},
    {"name": "floor", "mesh": 0}
  ],
  "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
  "buffers": [{"byteLength": 48, "uri": "data:application/octet-stream;base64,)" +
                           base64(buffer) + R"("}],
  "bufferViews": [
    {"buffer": 0, "byteOffset": 0, "byteLength": 36},
    {"buffer": 0, "byteOffset": 36, "byteLength": 12}
  ],
  "accessors": [
    {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
     "min": [0, 0, 0], "max": [1, 1, 0]},
    {"bufferView": 1, "componentType": 5125, "count": 3, "type": "SCALAR"}
  ]
})";
  test::TempDir dir;
  const auto file = test::writeText(dir / "nodes.gltf", gltf);
  const LoadedScene scene = loadScene(file, MeshLoadConfig{});
  ASSERT_EQ(scene.mesh.triangleCount(), 2u);
  ASSERT_EQ(scene.mesh.triangle_object.size(), 2u);
  int tagged = 0;
  for (size_t t = 0; t < 2; ++t) {
    Eigen::AlignedBox3f box;
    for (int k = 0; k < 3; ++k)
      box.extend(scene.mesh.positions[scene.mesh.indices[3 * t + k]]);
    if (scene.mesh.triangle_object[t] == 7) {
      ++tagged;
      // scaled by 2, then translated by 10 along x
      EXPECT_TRUE(box.min().isApprox(Vec3f(10, 0, 0)));
      EXPECT_TRUE(box.max().isApprox(Vec3f(12, 2, 0)));
    } else {
      EXPECT_EQ(scene.mesh.triangle_object[t], -1);
      EXPECT_TRUE(box.max().isApprox(Vec3f(1, 1, 0)));
    }
  }
  EXPECT_EQ(tagged, 1);
}

TEST(MeshImportTest, MissingFileNamesIt) {
  expectThrowWith<std::runtime_error>(
      [] { loadScene("/nonexistent/dir/house.glb", MeshLoadConfig{}); },
      {"/nonexistent/dir/house.glb", "does not exist"});
}

TEST(MeshImportTest, EmptyFileIsAnAssimpError) {
  test::TempDir dir;
  const auto file = test::writeText(dir / "empty.obj", "");
  expectThrowWith<std::runtime_error>(
      [&] { loadScene(file, MeshLoadConfig{}); },
      {"empty.obj", "assimp cannot read"});
}

TEST(MeshImportTest, GarbageBytesAreAnAssimpError) {
  test::TempDir dir;
  std::string garbage = "glTF";
  for (int i = 0; i < 200; ++i) garbage.push_back(static_cast<char>(i * 37));
  const auto file = test::writeText(dir / "garbage.glb", garbage);
  expectThrowWith<std::runtime_error>(
      [&] { loadScene(file, MeshLoadConfig{}); },
      {"garbage.glb", "assimp cannot read"});
}

TEST(MeshImportTest, ObjWithOnlyVerticesHasNoTriangles) {
  test::TempDir dir;
  const auto file =
      test::writeText(dir / "points.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n");
  expectThrowWith<std::invalid_argument>(
      [&] { loadScene(file, MeshLoadConfig{}); },
      {"points.obj", "no triangles"});
}

TEST(MeshImportTest, NanCoordinatesAreRejected) {
  test::TempDir dir;
  const auto file = test::writeText(
      dir / "nan.ply",
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
      "property float y\nproperty float z\nelement face 1\n"
      "property list uchar int vertex_indices\nend_header\n"
      "0 0 0\n1 nan 0\n0 1 0\n3 0 1 2\n");
  expectThrowWith<std::invalid_argument>(
      [&] { loadScene(file, MeshLoadConfig{}); }, {"nan.ply", "non-finite"});
}

// Hostile geometry in well-formed files (issue 19): refused with the file
// named before Recast or Embree could see it.
TEST(MeshImportTest, HugeTinyAndDegenerateGeometryIsRefused) {
  test::TempDir dir;
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"v 0 0 0\nv 1e30 0 0\nv 0 0 1\nf 1 2 3\n", "beyond +-1e+06 m"},
      {"v 0 0 0\nv 1 0 1\nv 2 0 2\nv 3 0 3\nf 1 2 3\nf 2 3 4\n",
       "all 2 triangles are degenerate"},
      {"v 0 0 0\nv 1e-30 0 0\nv 0 0 1e-30\nf 1 2 3\n",
       "zero area in single precision"},
      {"v 0 0 0\nv inf 0 0\nv 0 0 1\nf 1 2 3\n", "non-finite"},
  };
  for (size_t i = 0; i < cases.size(); ++i) {
    const std::string name = "hostile" + std::to_string(i) + ".obj";
    SCOPED_TRACE(cases[i].first);
    const auto file = test::writeText(dir / name, cases[i].first);
    expectThrowWith<std::invalid_argument>(
        [&] { loadScene(file, MeshLoadConfig{}); }, {name, cases[i].second});
  }
}

TEST(MeshImportTest, TheImportConfigIsCheckedWhenSetInCode) {
  // a scale of 0 would make every triangle degenerate, NaN every vertex
  test::TempDir dir;
  const auto file = test::writeText(dir / "cube.obj", kUnitCubeObj);
  for (float scale : {0.0f, NAN, 1e-30f, 1e30f}) {
    MeshLoadConfig config;
    config.scale = scale;
    expectThrowWith<std::invalid_argument>(
        [&] { loadScene(file, config); }, {"cube.obj", "mesh config", "scale"});
  }
}

// Writes each case's file text to <dir>/<stem><i>.ply and expects loadScene
// to refuse it with std::invalid_argument naming the file and the case's
// reason.
void expectEachRefused(
    const test::TempDir& dir, const std::string& stem,
    const std::vector<std::pair<std::string, std::string>>& cases) {
  for (size_t i = 0; i < cases.size(); ++i) {
    const std::string name = stem + std::to_string(i) + ".ply";
    const auto file = test::writeText(dir / name, cases[i].first);
    SCOPED_TRACE(cases[i].first);
    expectThrowWith<std::invalid_argument>(
        [&] { loadScene(file, MeshLoadConfig{}); }, {name, cases[i].second});
  }
}

// The PLY header guard of loadScene (Debian's assimp hangs or corrupts its
// heap on these; docs/reliability.md, fuzzing findings): each malformed
// header is refused before assimp reads it, naming the file and the reason.
TEST(MeshImportTest, MalformedPlyHeadersAreRefusedBeforeAssimp) {
  const std::string vertex =
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n";
  const std::string rest =
      "property float y\nproperty float z\nelement face 1\n"
      "property list uchar int vertex_indices\nend_header\n"
      "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
  const std::vector<std::pair<std::string, std::string>> cases = {
      {vertex + "property float y\nproperty float z\n", "no end_header"},
      {vertex + "property float z\nend_header\n0 0\n", "lacks x, y or z"},
      {vertex + "property flaot q\n" + rest, "malformed header line"},
      {vertex + "property float\n" + rest, "malformed header line"},
      {"ply\nformat ascii 1.0\nelement vertex\n" + rest,
       "expected 'element <name> <count>'"},
      {"ply\nformat ascii 1.0\nelement vertex -3\n" + rest,
       "expected 'element <name> <count>'"},
      {"ply\nformat utf8 1.0\nelement vertex 3\n" + rest, "expected 'format"},
      // assimp read one format and a body of the other (6.9 GB)
      {"ply\nformat ascii 1.0\nformat binary_little_endian 1.0\n"
       "element vertex 3\nproperty float x\n" +
           rest,
       "a second format line"},
      {"ply\nelement vertex 3\nproperty float x\n" + rest, "no format line"},
      {vertex + "ply\n" + rest, "'ply' after the first line"},
      {"ply\nproperty float x\n" + rest, "a property before any element"},
      {vertex + "vertex_count 3\n" + rest, "not a PLY header keyword"},
      // assimp sizes the vertex arrays by the first declaration, fills them
      // from both: a heap overflow
      {vertex + "property float y\nproperty float z\n" +
           "element vertex 3\nproperty float x\n" + rest,
       "an element declared twice"},
      {vertex + "property float x\n" + rest,
       "a property declared twice in its element"},
      // assimp does not end the header at "end_header\v" and loops
      {vertex + "property float y\nproperty float z\nend_header\v0 0 0\n",
       "not a PLY header keyword"},
  };
  test::TempDir dir;
  expectEachRefused(dir, "bad", cases);
  // the same lines in a well-formed order load
  const auto good = test::writeText(dir / "good.ply", vertex + rest);
  EXPECT_EQ(loadScene(good, MeshLoadConfig{}).mesh.triangleCount(), 1u);
}

// assimp's post-processing would read vertex 7 of 3 (a SEGV, found by fuzzing)
TEST(MeshImportTest, FaceNamingAMissingVertexIsRefused) {
  test::TempDir dir;
  const auto file = test::writeText(
      dir / "far.ply",
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
      "property float y\nproperty float z\nelement face 1\n"
      "property list uchar int vertex_indices\nend_header\n"
      "0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n");
  expectThrowWith<std::invalid_argument>(
      [&] { loadScene(file, MeshLoadConfig{}); },
      {"far.ply", "face 0 names vertex 7 of 3"});
}

// The PLY body walk of loadScene: a list count beyond its type or its line
// made Debian's assimp allocate gigabytes (found by fuzzing), and truncated
// bodies are refused rather than read as fewer rows.
TEST(MeshImportTest, MalformedAsciiPlyBodiesAreRefusedBeforeAssimp) {
  const std::string header =
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
      "property float y\nproperty float z\nelement face 1\n"
      "property list uchar int vertex_indices\nend_header\n";
  const std::string vertices = "0 0 0\n1 0 0\n0 1 0\n";
  const std::vector<std::pair<std::string, std::string>> cases = {
      {header + vertices + "3666666666666666 0 1 2\n",
       "row 0 property 'vertex_indices': list count '3666666666666666' is not "
       "an integer its count type holds"},
      {header + vertices + "256 0 1 2\n", "its count type holds"},
      {header + vertices + "4 0 1 2\n",
       "a list of 4 entries, but its line holds 3 more values"},
      {header + vertices + "3 0 1\n2\n", "but its line holds 2 more values"},
      {header + vertices, "element 'face' row 0: the file ends before it"},
      {header + "0 0 0\n\n\n1 0 0\n0 1 0\n3 0 1 2\n",
       "element 'vertex' row 1: a blank line where the row should be"},
      {header + "0 0 0\n1 0\n0 1 0\n3 0 1 2\n",
       "element 'vertex' row 1 property 'z': the row's line ends before its "
       "value"},
      {header + "0 0 0\n1 0x1 0\n0 1 0\n3 0 1 2\n", "'0x1' is not a number"},
      {header + "0 0 0\n1 0\v0\n0 1 0\n3 0 1 2\n",
       "element 'vertex' row 1: its line holds the byte \\x0b"},
      // assimp ends lines at a bare '\r' and at NUL too: after the NUL it
      // read a list of 999999999999 entries (20 GB) where this sees a row
      // with something left over
      {header + "0 0 0\r1 0 0\n0 1 0\n3 0 1 2\n", "holds the byte \\x0d"},
      {header + vertices +
           std::string("3 0 1 2\0"
                       "999999999999 1\n",
                       22),
       "element 'face' row 0: its line holds the byte \\x00"},
      {"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
       "property float y\nproperty float z\nelement junk 99999999999\n"
       "end_header\n" +
           vertices,
       "element 'junk' declares 99999999999 rows but no properties"},
      {"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
       "property float y\nproperty float z\nelement face 1\n"
       "property list float int vertex_indices\nend_header\n" +
           vertices + "3 0 1 2\n",
       "malformed header line"},
  };
  test::TempDir dir;
  expectEachRefused(dir, "body", cases);
  // \r\n line ends, tabs, '+' signs, exponents, values a row leaves over
  // and blank lines after the last row are all fine
  const auto good =
      test::writeText(dir / "good.ply",
                      header + "0 0 0\r\n+1\t0 0 9\r\n0 1e0 0\n3 0 1 2 \n\n\n");
  EXPECT_EQ(loadScene(good, MeshLoadConfig{}).mesh.triangleCount(), 1u);
}

namespace {

// A binary PLY triangle: three float vertices and one face whose list
// count (uchar or uint) is `count`, in the given byte order; `cut` bytes
// are dropped from the end.
std::string binaryPlyTriangle(bool bigEndian, bool uintCount, uint32_t count,
                              size_t cut = 0) {
  std::string out = std::string("ply\nformat ") +
                    (bigEndian ? "binary_big_endian" : "binary_little_endian") +
                    " 1.0\nelement vertex 3\nproperty float x\n"
                    "property float y\nproperty float z\nelement face 1\n"
                    "property list " +
                    (uintCount ? "uint" : "uchar") +
                    " int vertex_indices\nend_header\n";
  auto put = [&](const void* value, size_t bytes) {
    std::string raw(static_cast<const char*>(value), bytes);
    if (bigEndian) std::reverse(raw.begin(), raw.end());
    out += raw;
  };
  const float xyz[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  for (float v : xyz) put(&v, sizeof v);
  if (uintCount) {
    put(&count, sizeof count);
  } else {
    const auto small = static_cast<uint8_t>(count);
    put(&small, 1);
  }
  for (int32_t i = 0; i < 3; ++i) put(&i, sizeof i);
  out.resize(out.size() - cut);
  return out;
}

}  // namespace

TEST(MeshImportTest, BinaryPlyLoadsAndMalformedBodiesAreRefused) {
  test::TempDir dir;
  for (bool bigEndian : {false, true}) {
    for (bool uintCount : {false, true}) {
      SCOPED_TRACE(testing::Message() << "big endian " << bigEndian
                                      << ", uint count " << uintCount);
      const auto good = test::writeText(
          dir / "good.ply", binaryPlyTriangle(bigEndian, uintCount, 3));
      const TriangleMesh mesh = loadScene(good, MeshLoadConfig{}).mesh;
      ASSERT_EQ(mesh.triangleCount(), 1u);
      EXPECT_EQ(mesh.positions.size(), 3u);

      const auto cut = test::writeText(
          dir / "cut.ply", binaryPlyTriangle(bigEndian, uintCount, 3, 2));
      expectThrowWith<std::invalid_argument>(
          [&] { loadScene(cut, MeshLoadConfig{}); },
          {"cut.ply", "a list of 3 entries is longer than the 10 bytes left"});
    }
  }
  const auto huge = test::writeText(
      dir / "huge.ply", binaryPlyTriangle(false, true, 0xF0000000u));
  expectThrowWith<std::invalid_argument>(
      [&] { loadScene(huge, MeshLoadConfig{}); },
      {"huge.ply", "a list of 4026531840 entries is longer than the 12 bytes"});
  const auto noFace = test::writeText(dir / "noface.ply",
                                      binaryPlyTriangle(false, false, 3, 13));
  expectThrowWith<std::invalid_argument>(
      [&] { loadScene(noFace, MeshLoadConfig{}); },
      {"noface.ply",
       "element 'face' row 0 property 'vertex_indices': the "
       "file ends before it"});
}

}  // namespace
}  // namespace vln::sim
