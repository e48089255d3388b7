// Tests src/world/PathFacts.cpp: turn classes, which objects can be named,
// and the facts of a hand-made path (rooms, doorways, a landmark passed,
// where it stops).

#include "world/PathFacts.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <vector>

#include "world/InstructionTestHouse.h"

namespace vln::world::instruction {
namespace {

TEST(PathFactsTest, TurnsAreClassifiedByAngle) {
  EXPECT_EQ(classifyTurn(degToRad(10.0f)), TurnKind::kStraight);
  EXPECT_EQ(classifyTurn(degToRad(-20.0f)), TurnKind::kStraight);
  EXPECT_EQ(classifyTurn(degToRad(40.0f)), TurnKind::kSlightLeft);
  EXPECT_EQ(classifyTurn(degToRad(-40.0f)), TurnKind::kSlightRight);
  EXPECT_EQ(classifyTurn(degToRad(90.0f)), TurnKind::kLeft);
  EXPECT_EQ(classifyTurn(degToRad(-90.0f)), TurnKind::kRight);
  EXPECT_EQ(classifyTurn(degToRad(150.0f)), TurnKind::kSharpLeft);
  EXPECT_EQ(classifyTurn(degToRad(-150.0f)), TurnKind::kSharpRight);
  EXPECT_EQ(classifyTurn(degToRad(180.0f)), TurnKind::kAround);
  // angles wrap: 270 degrees left is 90 degrees right
  EXPECT_EQ(classifyTurn(degToRad(270.0f)), TurnKind::kRight);
}

TEST(PathFactsTest, ObjectsAloneInTheirRoomOrColourAreNameable) {
  const sim::SceneSemantics semantics = test::threeRooms();
  const std::vector<Nameability> names = nameability(semantics);
  ASSERT_EQ(names.size(), semantics.objects.size());
  // the bed (index 0) is the only one in the bedroom
  EXPECT_TRUE(names[0].nameable);
  EXPECT_FALSE(names[0].needs_color);
  // two chairs in the kitchen (indices 5, 6) differ by colour
  for (int chair : {5, 6}) {
    EXPECT_TRUE(names[static_cast<size_t>(chair)].nameable) << chair;
    EXPECT_TRUE(names[static_cast<size_t>(chair)].needs_color) << chair;
  }
}

TEST(PathFactsTest, BedroomToKitchenThroughTheHallway) {
  const sim::SceneSemantics semantics = test::threeRooms();
  const std::vector<Vec3f> path = test::bedroomToKitchen();
  const PathFacts f = analyzePath(semantics, path, /*startHeading=*/0.0f,
                                  InstructionConfig{}, nameability(semantics));

  // length along the legs, one heading per leg
  float total = 0.0f;
  for (size_t i = 0; i + 1 < path.size(); ++i)
    total += (path[i + 1] - path[i]).norm();
  EXPECT_NEAR(f.total, total, 1e-4f);
  EXPECT_EQ(f.heading.size(), path.size() - 1);
  ASSERT_FALSE(f.samples.empty());

  // bedroom, hallway, kitchen, each entered through a doorway
  std::vector<int> rooms;
  for (const Visit& v : f.visits) rooms.push_back(v.room);
  EXPECT_EQ(rooms, (std::vector<int>{0, 1, 2}));
  ASSERT_EQ(f.transitions.size(), 2u);
  EXPECT_EQ(f.transitions[0].from, 0);
  EXPECT_EQ(f.transitions[0].to, 1);
  EXPECT_TRUE(f.transitions[0].door);
  EXPECT_EQ(f.transitions[1].from, 1);
  EXPECT_EQ(f.transitions[1].to, 2);
  EXPECT_TRUE(f.transitions[1].door);
  EXPECT_FALSE(f.turns.empty());
  for (const Turn& t : f.turns) EXPECT_NE(t.kind, TurnKind::kStraight);

  // walking north (+z) up the hallway at x = 6, the plant (index 2) at
  // x = 6.6 is on the left
  const auto plant = std::find_if(f.passes.begin(), f.passes.end(),
                                  [](const Pass& p) { return p.object == 2; });
  ASSERT_NE(plant, f.passes.end());
  EXPECT_EQ(plant->side, Side::kLeft);
  EXPECT_GT(plant->lateral, 0.0f);

  // the goal is in the kitchen, 0.6 m from the fridge (index 3)
  EXPECT_EQ(f.stop.room, 2);
  EXPECT_EQ(f.stop.object, 3);
  EXPECT_FALSE(f.stop.door);
}

}  // namespace
}  // namespace vln::world::instruction
