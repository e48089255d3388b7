// The `vlnce-sim` binary (apps/SimMain.cpp) on scenes from the wild, each
// written by the test (issue 19): Z-up glTF rooms, a flat Z-up plane, a
// room in millimetres, and a render far outside the scene. Every one ends
// in the right answer or a clear error, never a crash; --up-axis, --scale
// and --config say what the file is.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "sim/MeshIo.h"
#include "sim/NavMesh.h"
#include "sim/SimTestScenes.h"
#include "support/TestPaths.h"
#include "support/TestUtil.h"

namespace vln::sim {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using ::testing::Not;

// What a Z-up file holds for a Y-up world mesh: world (x, y, z) stored as
// (x, -z, y) (Blender's glTF export without the Y-up conversion).
TriangleMesh asZUpFile(TriangleMesh mesh) {
  for (Vec3f& p : mesh.positions) p = Vec3f(p.x(), -p.z(), p.y());
  return mesh;
}

class SimBinaryTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!fs::exists(bin_)) GTEST_SKIP() << "build vlnce-sim first";
  }
  // Runs vlnce-sim with `args`; returns the exit status (a signal shows as
  // status > 128 from the shell), output in `output`.
  int run(const std::string& args, std::string* output) {
    return test::runCommand(bin_ + " " + args + " 2>&1", output);
  }
  // The "navigable area: X m^2" that `navmesh` printed, or -1.
  static float navigableArea(const std::string& output) {
    const auto at = output.find("navigable area: ");
    return at == std::string::npos ? -1.0f : std::stof(output.substr(at + 16));
  }
  // A Z-up `file`: read Y-up, `navmesh` fails with `why` and names
  // --up-axis z; read Z-up it succeeds. Returns that navigable area.
  float navigableAreaOnlyZUp(const fs::path& file, const std::string& why) {
    std::string output;
    EXPECT_EQ(run("navmesh --no-cache --scene " + file.string(), &output), 1);
    EXPECT_THAT(output, HasSubstr(why));
    EXPECT_THAT(output, HasSubstr("--up-axis z"));
    EXPECT_EQ(
        run("navmesh --no-cache --up-axis z --scene " + file.string(), &output),
        0)
        << output;
    return navigableArea(output);
  }
  const std::string bin_ = test::binary("vlnce-sim");
  test::TempDir dir_;
};

TEST_F(SimBinaryTest, AZUpGltfRoomNeedsUpAxisZ) {
  const fs::path file = dir_ / "room_zup.glb";
  saveScene(file, asZUpFile(test::roomWithTable()));
  const float area =
      NavMesh::build(test::roomWithTable(), NavMeshConfig{})->navigableArea();
  std::string output;
  // read Y-up: a warning saying what to do (and no floor)
  run("navmesh --no-cache --scene " + file.string(), &output);
  EXPECT_THAT(output, HasSubstr("looks Z-up"));
  EXPECT_THAT(output, HasSubstr("--up-axis z"));
  // read Z-up: the room
  ASSERT_EQ(
      run("navmesh --no-cache --up-axis z --scene " + file.string(), &output),
      0)
      << output;
  EXPECT_NEAR(navigableArea(output), area, 0.01f);
  EXPECT_THAT(output, Not(HasSubstr("looks Z-up")));
  // --config says the same through sim.mesh.up_axis
  const fs::path config =
      test::writeText(dir_ / "zup.yaml",
                      "trainer:\n  lr: 0.1\nsim:\n  mesh:\n    up_axis: z\n");
  ASSERT_EQ(run("navmesh --no-cache --config " + config.string() + " --scene " +
                    file.string(),
                &output),
            0)
      << output;
  EXPECT_NEAR(navigableArea(output), area, 0.01f);
}

TEST_F(SimBinaryTest, AZUpSlabRoomWithoutWallsGetsTheHintToo) {
  // the room: a floor slab with low furniture, no walls
  const fs::path file = dir_ / "slab_zup.glb";
  saveScene(file, asZUpFile(test::slabWithFurniture()));
  EXPECT_NEAR(navigableAreaOnlyZUp(file, "looks Z-up"),
              NavMesh::build(test::slabWithFurniture(), NavMeshConfig{})
                  ->navigableArea(),
              0.01f);
}

TEST_F(SimBinaryTest, AFlatZUpPlaneIsAnErrorNotACrash) {
  // was SIGSEGV inside rcRasterizeTriangles, exit 139
  const fs::path file = dir_ / "plane.glb";
  TriangleMesh plane;
  plane.positions = {{-10, -10, 0}, {10, -10, 0}, {10, 10, 0}, {-10, 10, 0}};
  plane.indices = {0, 1, 2, 0, 2, 3};
  saveScene(file, plane);
  EXPECT_NEAR(navigableAreaOnlyZUp(file, "flat along world z"), 19.75f * 19.75f,
              4.0f);
}

TEST_F(SimBinaryTest, AMillimetreRoomNeedsScale) {
  const fs::path file = dir_ / "room_mm.obj";
  TriangleMesh mm = test::roomWithTable();
  for (Vec3f& p : mm.positions) p *= 1000.0f;
  saveScene(file, mm);
  std::string output;
  EXPECT_EQ(run("navmesh --no-cache --scene " + file.string(), &output), 1);
  EXPECT_THAT(output, HasSubstr("check the mesh scale"));
  ASSERT_EQ(
      run("navmesh --no-cache --scale 0.001 --scene " + file.string(), &output),
      0)
      << output;
  EXPECT_NEAR(
      navigableArea(output),
      NavMesh::build(test::roomWithTable(), NavMeshConfig{})->navigableArea(),
      0.05f);
  // out of sim.mesh.scale's bounds
  EXPECT_EQ(
      run("navmesh --no-cache --scale 1e-30 --scene " + file.string(), &output),
      1);
  EXPECT_THAT(output, HasSubstr("sim.mesh.scale"));
}

TEST_F(SimBinaryTest, RenderingFarOutsideTheSceneIsAnError) {
  // was an Embree assertion (`all(valid, ray.valid())`), exit 134
  const fs::path file = dir_ / "room.obj";
  saveScene(file, test::roomWithTable());
  std::string output;
  for (const std::string backend : {"embree", "osmesa", "raster"}) {
    EXPECT_EQ(run("render --scene " + file.string() +
                      " --position 1e30,0,0 --heading 0 --backend " + backend +
                      " --width 8 --height 8 --out " + (dir_ / "out").string(),
                  &output),
              1);
    EXPECT_THAT(output, HasSubstr("--position 1e30,0,0"));
    EXPECT_THAT(output, HasSubstr("outside the scene"));
  }
  const int status = run("render --scene " + file.string() +
                             " --position 1,0,1 --heading nan --out " +
                             (dir_ / "out").string(),
                         &output);
  EXPECT_TRUE(status > 0 && status < 128) << status << ": " << output;
  // inside: a picture
  ASSERT_EQ(run("render --scene " + file.string() +
                    " --position 1,0,1 --heading 30 --width 8 --height 8 "
                    "--out " +
                    (dir_ / "out").string(),
                &output),
            0)
      << output;
  EXPECT_TRUE(fs::exists(dir_ / "out" / "rgb.png"));
}

TEST_F(SimBinaryTest, AConfigWithoutASimSectionKeepsTheDefaults) {
  const fs::path file = dir_ / "room.glb";
  saveScene(file, test::roomWithTable());
  const fs::path config =
      test::writeText(dir_ / "other.yaml", "trainer:\n  lr: 0.1\n");
  std::string output;
  EXPECT_EQ(run("navmesh --no-cache --config " + config.string() + " --scene " +
                    file.string(),
                &output),
            0)
      << output;
  const fs::path typo =
      test::writeText(dir_ / "typo.yaml", "sim:\n  mesh:\n    up_axes: z\n");
  EXPECT_EQ(run("navmesh --no-cache --config " + typo.string() + " --scene " +
                    file.string(),
                &output),
            1);
  EXPECT_THAT(output, HasSubstr("typo.yaml:3: unknown key 'sim.mesh.up_axes'"));
}

}  // namespace
}  // namespace vln::sim
