#include "sim/Scene.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <set>
#include <thread>
#include <vector>

#include "sim/GeometryCheck.h"
#include "sim/MeshIo.h"
#include "sim/SceneFileFixtures.h"
#include "sim/SimTestScenes.h"
#include "support/TestPaths.h"
#include "support/TestUtil.h"

namespace vln::sim {
namespace {

namespace fs = std::filesystem;
using test::addBox;
using test::roomWithTable;
using ::testing::HasSubstr;

// A bare 3 x 3 m slab: one island, clearly smaller than the room.
TriangleMesh smallSlab() {
  TriangleMesh m;
  addBox(m, {0, -0.1f, 0}, {3, 0, 3});
  return m;
}

SceneSemantics oneRoom() {
  SceneSemantics s;
  Room room;
  room.id = 0;
  room.type = "kitchen";
  room.footprint = Eigen::AlignedBox2f(Vec2f(0, 0), Vec2f(6, 6));
  s.rooms.push_back(room);
  return s;
}

// Moves a file's modification time `offset` away from another file's.
void setMtimeRelativeTo(const fs::path& file, const fs::path& reference,
                        std::chrono::seconds offset) {
  fs::last_write_time(file, fs::last_write_time(reference) + offset);
}

class SceneLoadTest : public ::testing::Test {
 protected:
  void SetUp() override {
    saveScene(sceneFile_, roomWithTable(), oneRoom());
    // the reference: the navmesh of the mesh as the loader returns it
    reference_ = NavMesh::build(loadScene(sceneFile_, MeshLoadConfig{}).mesh,
                                NavMeshConfig{});
  }
  // Writes another navmesh of the same room as the cache: regions as large
  // as 30 x 30 cells drop the table's island, the bounds stay the room's.
  void writeOtherRoomCache() const {
    NavMeshConfig coarse;
    coarse.region_min_size = 30.0f;
    NavMesh::build(roomWithTable(), coarse)->save(cacheFile_);
  }
  // True when `navmesh` is the room's (not the slab's or the coarse one).
  bool isRoomNavmesh(const NavMesh& navmesh) const {
    return navmesh.islandCount() == 2 &&
           navmesh.navigableArea() == reference_->navigableArea();
  }
  test::TempDir dir_;
  fs::path sceneFile_ = dir_ / "kitchen.glb";
  fs::path cacheFile_ = dir_ / "kitchen.glb.navmesh";
  std::unique_ptr<NavMesh> reference_;
};

// ---------------------------------------------------------------------------
// fromMesh
// ---------------------------------------------------------------------------

TEST(SceneFromMesh, KeepsTheMeshAndBuildsTheNavmesh) {
  const TriangleMesh mesh = roomWithTable();
  const auto scene =
      Scene::fromMesh("house_7", mesh, oneRoom(), NavMeshConfig{});
  EXPECT_EQ(scene->name(), "house_7");
  EXPECT_EQ(scene->mesh(), mesh);
  EXPECT_EQ(scene->semantics(), oneRoom());
  EXPECT_EQ(scene->navmesh().islandCount(), 2);
  EXPECT_TRUE(scene->navmesh().isNavigable({1.0f, 0.0f, 1.0f}));
}

TEST(SceneFromMesh, ErrorsNameTheScene) {
  TriangleMesh wall;
  addBox(wall, {0, 0, 0}, {4, 2.5f, 0.1f});
  try {
    Scene::fromMesh("lonely_wall", wall, {}, NavMeshConfig{});
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("lonely_wall"));
    EXPECT_THAT(e.what(), HasSubstr("no walkable surface"));
  }
}

TEST(SceneFromMesh, RayTracerIsBuiltOnceForAllThreads) {
  const auto scene =
      Scene::fromMesh("room", roomWithTable(), {}, NavMeshConfig{});
  constexpr int kThreads = 4;
  std::vector<const RayTracer*> seen(kThreads, nullptr);
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t)
    threads.emplace_back(
        [&, t] { seen[static_cast<size_t>(t)] = &scene->rayTracer(); });
  for (auto& thread : threads) thread.join();
  EXPECT_EQ(std::set<const RayTracer*>(seen.begin(), seen.end()).size(), 1u);
  EXPECT_EQ(&scene->rayTracer(), seen[0]);
  EXPECT_EQ(&scene->rayTracer().mesh(), &scene->mesh());

  // it traces the scene's own triangles: straight down onto the floor
  const auto hit =
      scene->rayTracer().cast({1.0f, 2.0f, 1.0f}, {0.0f, -1.0f, 0.0f});
  ASSERT_TRUE(hit.has_value());
  EXPECT_NEAR(hit->distance, 2.0f, 1e-4f);
}

// ---------------------------------------------------------------------------
// load and the navmesh cache
// ---------------------------------------------------------------------------

TEST_F(SceneLoadTest, BuildsAndCachesTheNavmesh) {
  ASSERT_FALSE(fs::exists(cacheFile_));
  const auto scene = Scene::load(sceneFile_, SimConfig{});
  EXPECT_EQ(scene->name(), "kitchen");
  EXPECT_EQ(scene->semantics(), oneRoom());
  EXPECT_TRUE(isRoomNavmesh(scene->navmesh()));
  ASSERT_TRUE(fs::exists(cacheFile_));
  EXPECT_TRUE(isRoomNavmesh(*NavMesh::load(cacheFile_)));
}

TEST_F(SceneLoadTest, UsesACacheNewerThanTheScene) {
  // a different navmesh of the same room in the cache proves it was read,
  // not rebuilt
  writeOtherRoomCache();
  setMtimeRelativeTo(cacheFile_, sceneFile_, std::chrono::seconds(10));
  const auto scene = Scene::load(sceneFile_, SimConfig{});
  EXPECT_EQ(scene->navmesh().islandCount(), 1);
}

TEST_F(SceneLoadTest, RebuildsACacheOfAnotherMesh) {
  // the slab's navmesh spans 3 x 3 m, the room 6 x 6 m: another mesh (or
  // the same file read with another up axis or scale)
  NavMesh::build(smallSlab(), NavMeshConfig{})->save(cacheFile_);
  setMtimeRelativeTo(cacheFile_, sceneFile_, std::chrono::seconds(10));
  const auto scene = Scene::load(sceneFile_, SimConfig{});
  EXPECT_TRUE(isRoomNavmesh(scene->navmesh()));
}

TEST_F(SceneLoadTest, RebuildsACacheOlderThanTheScene) {
  writeOtherRoomCache();
  setMtimeRelativeTo(cacheFile_, sceneFile_, std::chrono::seconds(-10));
  const auto scene = Scene::load(sceneFile_, SimConfig{});
  EXPECT_TRUE(isRoomNavmesh(scene->navmesh()));
  // and replaces it
  EXPECT_TRUE(isRoomNavmesh(*NavMesh::load(cacheFile_)));
}

TEST_F(SceneLoadTest, RebuildsACacheBuiltForAnotherAgent) {
  NavMeshConfig wide;
  wide.agent_radius = 0.3f;
  NavMesh::build(roomWithTable(), wide)->save(cacheFile_);
  setMtimeRelativeTo(cacheFile_, sceneFile_, std::chrono::seconds(10));
  const auto scene = Scene::load(sceneFile_, SimConfig{});
  EXPECT_EQ(scene->navmesh().config().agent_radius,
            NavMeshConfig{}.agent_radius);
  EXPECT_TRUE(isRoomNavmesh(scene->navmesh()));
}

TEST_F(SceneLoadTest, AnotherAgentsNavmeshGoesBesideTheCache) {
  // RxR's 0.18 m agent on a scene cached for R2R's 0.1 m one: the cache is
  // kept for R2R and RxR's navmesh built into its own file, so the two
  // tasks do not rebuild each other's navmeshes
  const auto r2r = Scene::load(sceneFile_, SimConfig{});
  const std::string r2rBytes = test::readText(cacheFile_);
  SimConfig rxr;
  rxr.navmesh.agent_radius = 0.18f;
  rxr.navmesh.agent_height = 0.88f;
  const fs::path variant = navMeshVariantFile(sceneFile_, rxr.navmesh);
  EXPECT_EQ(variant.filename(), "kitchen.glb.agent_r180_h880_c200.navmesh");
  const auto first = Scene::load(sceneFile_, rxr);
  EXPECT_EQ(first->navmesh().config().agent_radius, 0.18f);
  EXPECT_EQ(test::readText(cacheFile_), r2rBytes);
  ASSERT_TRUE(fs::exists(variant));
  EXPECT_EQ(NavMesh::load(variant)->config().agent_radius, 0.18f);

  // both are read back, not rebuilt: a variant holding another navmesh of
  // the room for this agent (coarser voxels) proves it was read
  NavMeshConfig coarse = rxr.navmesh;
  coarse.cell_size = 0.1f;
  const auto other = NavMesh::build(roomWithTable(), coarse);
  ASSERT_NE(other->navigableArea(), first->navmesh().navigableArea());
  other->save(variant);
  setMtimeRelativeTo(variant, sceneFile_, std::chrono::seconds(10));
  setMtimeRelativeTo(cacheFile_, sceneFile_, std::chrono::seconds(10));
  EXPECT_EQ(Scene::load(sceneFile_, rxr)->navmesh().navigableArea(),
            other->navigableArea());
  EXPECT_TRUE(isRoomNavmesh(Scene::load(sceneFile_, SimConfig{})->navmesh()));
}

TEST_F(SceneLoadTest, RebuildsACorruptCache) {
  test::writeText(cacheFile_, "not a navmesh at all, just some text");
  setMtimeRelativeTo(cacheFile_, sceneFile_, std::chrono::seconds(10));
  const auto scene = Scene::load(sceneFile_, SimConfig{});
  EXPECT_TRUE(isRoomNavmesh(scene->navmesh()));
  EXPECT_TRUE(isRoomNavmesh(*NavMesh::load(cacheFile_)));
}

TEST_F(SceneLoadTest, WithoutCachingNoFileIsReadOrWritten) {
  SimConfig config;
  config.cache_navmesh = false;
  const auto scene = Scene::load(sceneFile_, config);
  EXPECT_TRUE(isRoomNavmesh(scene->navmesh()));
  EXPECT_FALSE(fs::exists(cacheFile_));

  writeOtherRoomCache();
  setMtimeRelativeTo(cacheFile_, sceneFile_, std::chrono::seconds(10));
  EXPECT_TRUE(isRoomNavmesh(Scene::load(sceneFile_, config)->navmesh()));
}

TEST_F(SceneLoadTest, UsesTheNavmeshConfig) {
  SimConfig config;
  config.navmesh.agent_radius = 0.3f;
  const auto scene = Scene::load(sceneFile_, config);
  EXPECT_EQ(scene->navmesh().config().agent_radius, 0.3f);
  // a fatter agent has less room
  EXPECT_LT(scene->navmesh().navigableArea(),
            reference_->navigableArea() - 1.0f);
}

TEST(SceneLoad, MissingFileIsNamed) {
  test::TempDir dir;
  const fs::path missing = dir / "nowhere.glb";
  try {
    Scene::load(missing, SimConfig{});
    FAIL() << "expected an exception";
  } catch (const std::exception& e) {
    EXPECT_THAT(e.what(), HasSubstr(missing.string()));
  }
}

TEST(SceneLoad, UnwalkableSceneIsNamed) {
  test::TempDir dir;
  const fs::path file = dir / "wall.glb";
  TriangleMesh wall;
  addBox(wall, {0, 0, 0}, {4, 2.5f, 0.1f});
  saveScene(file, wall);
  try {
    Scene::load(file, SimConfig{});
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr(file.string()));
    EXPECT_THAT(e.what(), HasSubstr("no walkable surface"));
  }
  EXPECT_FALSE(fs::exists(dir / "wall.glb.navmesh"));
}

// ---------------------------------------------------------------------------
// scenes from the wild (issue 19): other up axes and units
// ---------------------------------------------------------------------------

// What a Z-up file holds for a Y-up world mesh: world (x, y, z) stored as
// (x, -z, y), as Blender exports without the Y-up conversion.
TriangleMesh asZUpFile(TriangleMesh mesh) {
  for (Vec3f& p : mesh.positions) p = Vec3f(p.x(), -p.z(), p.y());
  return mesh;
}

SimConfig withMesh(UpAxis upAxis, float scale, bool cache = false) {
  SimConfig config;
  config.mesh.up_axis = upAxis;
  config.mesh.scale = scale;
  config.cache_navmesh = cache;
  return config;
}

TEST(SceneLoad, AZUpGltfRoomLoadsWithUpAxisZ) {
  test::TempDir dir;
  const fs::path file = dir / "room_zup.glb";
  saveScene(file, asZUpFile(roomWithTable()));
  const auto reference = NavMesh::build(roomWithTable(), NavMeshConfig{});
  // read Z-up it is the room: the same navmesh as the Y-up original
  const auto zUp = Scene::load(file, withMesh(UpAxis::kZ, 1.0f));
  EXPECT_EQ(zUp->navmesh().islandCount(), 2);
  EXPECT_NEAR(zUp->navmesh().navigableArea(), reference->navigableArea(),
              0.01f);
  // read Y-up the floor stands on edge and two walls lie flat: a wrong
  // navmesh, which loadScene() warns about
  const auto yUp = Scene::load(file, withMesh(UpAxis::kY, 1.0f));
  EXPECT_GT(
      std::abs(yUp->navmesh().navigableArea() - reference->navigableArea()),
      1.0f);
  const std::string hint =
      upAxisHint(loadScene(file, MeshLoadConfig{}).mesh, MeshLoadConfig{});
  EXPECT_THAT(hint, HasSubstr("looks Z-up"));
  EXPECT_THAT(hint, HasSubstr("--up-axis z"));
}

TEST(SceneLoad, AFlatZUpPlaneReadYUpIsAClearError) {
  // a 20 m x 20 m plane authored Z-up: read Y-up it has zero extent along
  // world z, which crashed Recast (SIGSEGV in rcRasterizeTriangles)
  test::TempDir dir;
  const fs::path file = dir / "plane.glb";
  TriangleMesh plane;
  plane.positions = {{-10, -10, 0}, {10, -10, 0}, {10, 10, 0}, {-10, 10, 0}};
  plane.indices = {0, 1, 2, 0, 2, 3};
  saveScene(file, plane);
  test::expectThrowWith<std::invalid_argument>(
      [&] { Scene::load(file, withMesh(UpAxis::kY, 1.0f)); },
      {file.string(), "flat along world z", "looks Z-up", "--up-axis z"});
  const auto zUp = Scene::load(file, withMesh(UpAxis::kZ, 1.0f));
  EXPECT_NEAR(zUp->navmesh().navigableArea(), 19.75f * 19.75f, 4.0f);
}

TEST(SceneLoad, AMillimetreRoomLoadsWithItsScale) {
  // the 6 m room written in millimetres: 1.2e5 x 1.2e5 cells at the default
  // scale, refused with a hint; scale 0.001 gives the room's navmesh
  test::TempDir dir;
  const fs::path file = dir / "room_mm.obj";
  TriangleMesh mm = roomWithTable();
  for (Vec3f& p : mm.positions) p *= 1000.0f;
  saveScene(file, mm);
  test::expectThrowWith<std::invalid_argument>(
      [&] { Scene::load(file, withMesh(UpAxis::kY, 1.0f)); },
      {file.string(), "more than 1e+08 cells, check the mesh scale"});
  const auto metres = Scene::load(file, withMesh(UpAxis::kY, 0.001f));
  const auto reference = NavMesh::build(roomWithTable(), NavMeshConfig{});
  EXPECT_EQ(metres->navmesh().islandCount(), 2);
  EXPECT_NEAR(metres->navmesh().navigableArea(), reference->navigableArea(),
              0.05f);
}

TEST(SceneLoad, ACacheBuiltWithAnotherScaleIsRebuilt) {
  // the cache of the file read one way must not answer for another: it is
  // newer than the scene and built for the same agent, but spans other
  // bounds
  test::TempDir dir;
  const fs::path file = dir / "room_zup.glb";
  saveScene(file, asZUpFile(roomWithTable()));
  const float doubledArea =
      Scene::load(file, withMesh(UpAxis::kZ, 2.0f, /*cache=*/true))
          ->navmesh()
          .navigableArea();
  ASSERT_TRUE(fs::exists(dir / "room_zup.glb.navmesh"));
  const auto right = Scene::load(file, withMesh(UpAxis::kZ, 1.0f, true));
  const float area =
      NavMesh::build(roomWithTable(), NavMeshConfig{})->navigableArea();
  EXPECT_GT(doubledArea, 3.0f * area);
  EXPECT_NEAR(right->navmesh().navigableArea(), area, 0.01f);
}

}  // namespace
}  // namespace vln::sim
