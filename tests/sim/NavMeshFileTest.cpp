// Tests src/sim/NavMeshFile.cpp through NavMesh::save() and load(): the
// Habitat "MSET" layout, round trips, and corrupt files refused with the
// file named. (NavMeshFile.h itself includes Detour, which only vln_sim
// sees.)

#include "sim/NavMesh.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstring>
#include <memory>
#include <random>
#include <stdexcept>
#include <string>

#include "common/FileIo.h"
#include "sim/SimTestScenes.h"
#include "support/TestPaths.h"

namespace vln::sim {
namespace {

using ::testing::HasSubstr;

// The navmesh of the room with a table (SimTestScenes.h), built once.
const NavMesh& room() {
  static const std::unique_ptr<NavMesh> navmesh =
      NavMesh::build(test::roomWithTable(), NavMeshConfig{});
  return *navmesh;
}

TEST(NavMeshFileTest, SaveLoadRoundTripGivesIdenticalQueries) {
  test::TempDir dir;
  const auto file = dir / "room.navmesh";
  room().save(file);
  const auto loaded = NavMesh::load(file);

  EXPECT_EQ(loaded->polygonCount(), room().polygonCount());
  EXPECT_EQ(loaded->islandCount(), room().islandCount());
  EXPECT_EQ(loaded->navigableArea(), room().navigableArea());
  EXPECT_EQ(loaded->triangles(), room().triangles());
  EXPECT_EQ(loaded->config().agent_radius, NavMeshConfig{}.agent_radius);
  EXPECT_EQ(loaded->config().agent_height, NavMeshConfig{}.agent_height);

  std::mt19937_64 a(5), b(5);
  for (int i = 0; i < 100; ++i) {
    const Vec3f p = room().randomPoint(a), q = room().randomPoint(a);
    EXPECT_EQ(loaded->randomPoint(b), p);
    EXPECT_EQ(loaded->randomPoint(b), q);
    EXPECT_EQ(loaded->geodesicDistance(p, q), room().geodesicDistance(p, q));
    EXPECT_EQ(loaded->islandIndex(p), room().islandIndex(p));
    EXPECT_EQ(loaded->moveAlongSurface(p, q), room().moveAlongSurface(p, q));
  }

  // saving what was loaded reproduces the file byte for byte
  const auto again = dir / "again.navmesh";
  loaded->save(again);
  EXPECT_EQ(common::readFile(file), common::readFile(again));
}

TEST(NavMeshFileTest, SavedFileHasTheMsetLayout) {
  test::TempDir dir;
  const auto file = dir / "room.navmesh";
  room().save(file);
  const std::string bytes = common::readFile(file);
  // 'MSET' as a little-endian int, version 1, one tile
  ASSERT_GE(bytes.size(), 48u);
  EXPECT_EQ(bytes.substr(0, 4), "TESM");
  EXPECT_EQ(bytes[4], 1);
  EXPECT_EQ(bytes[8], 1);
  // the tile data starts with Detour's 'DNAV' magic
  EXPECT_EQ(bytes.substr(48, 4), "VAND");
}

class CorruptNavMeshTest : public ::testing::Test {
 protected:
  void SetUp() override {
    room().save(good_);
    bytes_ = common::readFile(good_);
  }
  // Writes `bytes` to a file and returns the message NavMesh::load throws.
  std::string loadError(const std::string& bytes) {
    const auto file = dir_ / "corrupt.navmesh";
    test::writeText(file, bytes);
    try {
      NavMesh::load(file);
    } catch (const std::runtime_error& e) {
      EXPECT_THAT(e.what(), HasSubstr(file.string()));
      return e.what();
    }
    ADD_FAILURE() << "no error loading a corrupt navmesh";
    return {};
  }
  test::TempDir dir_;
  std::filesystem::path good_ = dir_ / "good.navmesh";
  std::string bytes_;
};

TEST_F(CorruptNavMeshTest, TruncatedFilesAreReported) {
  EXPECT_THAT(loadError(bytes_.substr(0, 20)), HasSubstr("truncated"));
  EXPECT_THAT(loadError(bytes_.substr(0, 44)), HasSubstr("truncated"));
  EXPECT_THAT(loadError(bytes_.substr(0, bytes_.size() / 2)),
              HasSubstr("truncated"));
  EXPECT_THAT(loadError(bytes_.substr(0, bytes_.size() - 1)),
              HasSubstr("truncated"));
}

TEST_F(CorruptNavMeshTest, WrongMagicAndVersionAreReported) {
  std::string wrong = bytes_;
  wrong[0] = 'X';
  EXPECT_THAT(loadError(wrong), HasSubstr("not a navmesh"));
  EXPECT_THAT(loadError(std::string(100, 'a')), HasSubstr("not a navmesh"));
  std::string version = bytes_;
  version[4] = 7;
  EXPECT_THAT(loadError(version), HasSubstr("version"));
}

TEST_F(CorruptNavMeshTest, CorruptTilesAreReported) {
  // tile magic (first bytes of the tile data)
  std::string magic = bytes_;
  magic[48] = 'Z';
  EXPECT_THAT(loadError(magic), HasSubstr("corrupt tile 0"));
  // polygon count (dtMeshHeader field 7, byte 24 of the tile) far too large
  std::string count = bytes_;
  const int32_t huge = 1 << 20;
  std::memcpy(&count[48 + 24], &huge, sizeof(huge));
  EXPECT_THAT(loadError(count), HasSubstr("corrupt tile 0"));
  // the header's tile count disagrees with maxTiles
  std::string tiles = bytes_;
  tiles[8] = 9;
  EXPECT_THAT(loadError(tiles), HasSubstr("corrupt header"));
}

TEST_F(CorruptNavMeshTest, LoadsFilesWithoutDetailEdgeFlags) {
  // Detour dereferences null in closestPointOnPoly when no detail edge of a
  // polygon is flagged as outline (recastnavigation #394/#656); files from
  // tools that leave the flags at 0 must still work. Offsets follow Detour's
  // tile layout: 100-byte dtMeshHeader (counts at bytes 24..47), then
  // vertices (12 B), polygons (32 B), links (12 B), detail meshes (12 B),
  // detail vertices (12 B) and detail triangles (4 B: 3 indices + flags).
  constexpr size_t kTile = 48;
  auto count = [&](size_t at) {
    int32_t v;
    std::memcpy(&v, &bytes_[kTile + at], sizeof(v));
    return static_cast<size_t>(v);
  };
  const size_t detailTris = kTile + 100 + 12 * count(28) + 32 * count(24) +
                            12 * count(32) + 12 * count(36) + 12 * count(40);
  std::string unflagged = bytes_;
  for (size_t t = 0; t < count(44); ++t) unflagged[detailTris + 4 * t + 3] = 0;
  ASSERT_NE(unflagged, bytes_);  // there were flags to clear

  const auto file = dir_ / "unflagged.navmesh";
  test::writeText(file, unflagged);
  const auto loaded = NavMesh::load(file);
  // snapping from outside every polygon runs the edge search
  const auto edge = loaded->snapPoint({-0.06f, 0.0f, 1.0f});
  ASSERT_TRUE(edge.has_value());
  EXPECT_EQ(*edge, *room().snapPoint({-0.06f, 0.0f, 1.0f}));
  EXPECT_EQ(loaded->geodesicDistance({1, 0, 1}, {5, 0, 5}),
            room().geodesicDistance({1, 0, 1}, {5, 0, 5}));
}

TEST_F(CorruptNavMeshTest, MissingFileNamesTheFile) {
  const auto missing = dir_ / "missing.navmesh";
  try {
    NavMesh::load(missing);
    FAIL() << "expected std::runtime_error";
  } catch (const std::runtime_error& e) {
    EXPECT_THAT(e.what(), HasSubstr(missing.string()));
  }
}

}  // namespace
}  // namespace vln::sim
