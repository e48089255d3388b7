#include "sim/Scene.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <set>
#include <thread>
#include <vector>

#include "sim/MeshIo.h"
#include "sim/SimTestScenes.h"
#include "support/TestPaths.h"

namespace vln::sim {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using test::addBox;
using test::roomWithTable;

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
  // True when `navmesh` is the room's (not the slab's).
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
  // a different navmesh in the cache proves it was read, not rebuilt
  NavMesh::build(smallSlab(), NavMeshConfig{})->save(cacheFile_);
  setMtimeRelativeTo(cacheFile_, sceneFile_, std::chrono::seconds(10));
  const auto scene = Scene::load(sceneFile_, SimConfig{});
  EXPECT_EQ(scene->navmesh().islandCount(), 1);
  EXPECT_LT(scene->navmesh().navigableArea(), 10.0f);
}

TEST_F(SceneLoadTest, RebuildsACacheOlderThanTheScene) {
  NavMesh::build(smallSlab(), NavMeshConfig{})->save(cacheFile_);
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

  NavMesh::build(smallSlab(), NavMeshConfig{})->save(cacheFile_);
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

}  // namespace
}  // namespace vln::sim
