// Tests src/world/CaptureDifferences.cpp on generated houses: closed doors
// and moved objects as configured, nothing when both chances are zero, and
// the same changes for the same seed.

#include "world/CaptureDifferences.h"

#include <gtest/gtest.h>

#include <cstdint>

#include "sim/RayTracer.h"
#include "world/HouseGenerator.h"
#include "world/NavGraphBuilder.h"
#include "world/WorldConfig.h"

namespace vln::world {
namespace {

struct Captured {
  House house;
  BuiltNavGraph graph;
};

Captured capture(uint64_t seed) {
  Captured c{generateHouse(seed, HouseConfig{}), {}};
  const sim::RayTracer tracer(c.house.mesh);
  c.graph =
      buildNavGraph(c.house.semantics, tracer, NavGraphBuildConfig{}, seed + 1);
  return c;
}

WorldConfig withChances(float closedDoor, float movedObject) {
  WorldConfig config;
  config.reconstruction.closed_door_probability = closedDoor;
  config.reconstruction.moved_object_probability = movedObject;
  return config;
}

TEST(CaptureDifferencesTest, ZeroChancesChangeNothing) {
  Captured c = capture(3);
  const size_t triangles = c.house.mesh.triangleCount();
  const size_t objects = c.house.semantics.objects.size();
  const CaptureDifferences made = applyCaptureDifferences(
      c.house, c.graph, withChances(0.0f, 0.0f), /*seed=*/9);
  EXPECT_EQ(made.closed_doors, 0);
  EXPECT_EQ(made.moved_objects, 0);
  EXPECT_EQ(c.house.mesh.triangleCount(), triangles);
  EXPECT_EQ(c.house.semantics.objects.size(), objects);
}

TEST(CaptureDifferencesTest, EveryInteriorDoorClosesWithChanceOne) {
  Captured c = capture(4);
  int interior = 0;
  for (const sim::Doorway& door : c.house.semantics.doors)
    interior += door.room_a >= 0 && door.room_b >= 0 ? 1 : 0;
  ASSERT_GT(interior, 0);
  const size_t triangles = c.house.mesh.triangleCount();
  const CaptureDifferences made = applyCaptureDifferences(
      c.house, c.graph, withChances(1.0f, 0.0f), /*seed=*/9);
  EXPECT_EQ(made.closed_doors, interior);
  EXPECT_EQ(made.moved_objects, 0);
  // one closed box of 12 triangles per leaf
  EXPECT_EQ(c.house.mesh.triangleCount(),
            triangles + 12 * static_cast<size_t>(interior));
  c.house.mesh.validate("closed doors");
}

TEST(CaptureDifferencesTest, MovedObjectsAreNewObjectsInTheirRoom) {
  Captured c = capture(5);
  const size_t objects = c.house.semantics.objects.size();
  const CaptureDifferences made = applyCaptureDifferences(
      c.house, c.graph, withChances(0.0f, 1.0f), /*seed=*/9);
  EXPECT_GT(made.moved_objects, 0);
  ASSERT_EQ(c.house.semantics.objects.size(),
            objects + static_cast<size_t>(made.moved_objects));
  for (size_t i = objects; i < c.house.semantics.objects.size(); ++i) {
    const sim::SemanticObject& moved = c.house.semantics.objects[i];
    ASSERT_GE(moved.room, 0);
    const sim::Room& room =
        c.house.semantics.rooms[static_cast<size_t>(moved.room)];
    EXPECT_TRUE(room.footprint.contains(Eigen::AlignedBox2f(
        Vec2f(moved.bounds.min().x(), moved.bounds.min().z()),
        Vec2f(moved.bounds.max().x(), moved.bounds.max().z()))))
        << "object " << moved.id;
    // its triangles carry its new id
    bool tagged = false;
    for (int32_t id : c.house.mesh.triangle_object) tagged |= id == moved.id;
    EXPECT_TRUE(tagged) << "object " << moved.id;
  }
  c.house.mesh.validate("moved objects");
}

TEST(CaptureDifferencesTest, SameSeedSameChanges) {
  Captured a = capture(6), b = capture(6);
  const WorldConfig config = withChances(0.5f, 0.2f);
  const CaptureDifferences madeA =
      applyCaptureDifferences(a.house, a.graph, config, /*seed=*/21);
  const CaptureDifferences madeB =
      applyCaptureDifferences(b.house, b.graph, config, /*seed=*/21);
  EXPECT_EQ(madeA.closed_doors, madeB.closed_doors);
  EXPECT_EQ(madeA.moved_objects, madeB.moved_objects);
  EXPECT_EQ(a.house.mesh.positions, b.house.mesh.positions);
  EXPECT_EQ(a.house.semantics, b.house.semantics);
}

}  // namespace
}  // namespace vln::world
