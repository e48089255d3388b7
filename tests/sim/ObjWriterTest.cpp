#include "sim/ObjWriter.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "common/FileIo.h"
#include "sim/SceneFileFixtures.h"
#include "support/TestPaths.h"

namespace vln::sim {
namespace {

using test::checkerTexture;
using test::expectThrowWith;
using test::featureMesh;
using ::testing::HasSubstr;

// The lines of `text` that start with `prefix` (e.g. "v ").
std::vector<std::string> linesStartingWith(const std::string& text,
                                           const std::string& prefix) {
  std::vector<std::string> out;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);)
    if (line.rfind(prefix, 0) == 0) out.push_back(line);
  return out;
}

TEST(ObjWriterTest, WritesGroupsMaterialsColoursAndTextures) {
  test::TempDir dir;
  const TriangleMesh mesh = featureMesh();
  writeObj(dir / "scene.obj", mesh);
  const std::string obj = common::readFile(dir / "scene.obj");
  const std::string mtl = common::readFile(dir / "scene.mtl");

  EXPECT_THAT(obj, HasSubstr("mtllib scene.mtl\n"));
  // one group per object, structure first (object -1), then ascending ids
  EXPECT_THAT(
      linesStartingWith(obj, "o "),
      ::testing::ElementsAre("o structure", "o object_3", "o object_12"));
  // the material-less structure names assimp's default explicitly
  EXPECT_THAT(linesStartingWith(obj, "usemtl "),
              ::testing::ElementsAre("usemtl DefaultMaterial", "usemtl painted",
                                     "usemtl wood"));
  // every vertex carries its colour: "v x y z r g b"
  const auto vertices = linesStartingWith(obj, "v ");
  ASSERT_EQ(vertices.size(), mesh.positions.size());
  for (const std::string& line : vertices) {
    std::istringstream values(line.substr(2));
    int count = 0;
    for (float value; values >> value;) ++count;
    EXPECT_EQ(count, 6) << line;
  }
  EXPECT_EQ(linesStartingWith(obj, "vt ").size(), mesh.uvs.size());
  EXPECT_EQ(linesStartingWith(obj, "f ").size(), mesh.triangleCount());

  EXPECT_THAT(mtl, HasSubstr("newmtl painted\nKd 0.25 0.5 1\nillum 0\n"));
  EXPECT_THAT(mtl, HasSubstr("newmtl wood\nKd 1 1 1\nillum 0\n"
                             "map_Kd scene_planks.png\n"));
  EXPECT_EQ(common::readFile(dir / "scene_planks.png").substr(1, 3), "PNG");
}

TEST(ObjWriterTest, WhitespaceInNamesBecomesUnderscores) {
  test::TempDir dir;
  TriangleMesh mesh = featureMesh();
  mesh.materials[0].name = "dark\twood";
  mesh.textures[0].name = "old planks";
  writeObj(dir / "scene.obj", mesh);
  EXPECT_THAT(common::readFile(dir / "scene.obj"),
              HasSubstr("usemtl dark_wood\n"));
  EXPECT_THAT(common::readFile(dir / "scene.mtl"),
              HasSubstr("map_Kd scene_old_planks.png\n"));
}

TEST(ObjWriterTest, RefusesNamesThatWouldCollide) {
  test::TempDir dir;
  TriangleMesh twoMaterials = featureMesh();
  twoMaterials.materials[1].name = "painted";
  expectThrowWith<std::invalid_argument>(
      [&] { writeObj(dir / "a.obj", twoMaterials); },
      {"a.obj", "two materials are both named 'painted'"});

  TriangleMesh reserved = featureMesh();
  reserved.materials[0].name = "DefaultMaterial";
  expectThrowWith<std::invalid_argument>(
      [&] { writeObj(dir / "b.obj", reserved); },
      {"b.obj", "'DefaultMaterial' is reserved"});

  TriangleMesh twoTextures = featureMesh();
  twoTextures.textures.push_back(checkerTexture("planks"));
  twoTextures.materials[0].texture = 1;
  expectThrowWith<std::invalid_argument>(
      [&] { writeObj(dir / "c.obj", twoTextures); },
      {"c.obj", "two textures are both named 'planks'"});
}

}  // namespace
}  // namespace vln::sim
