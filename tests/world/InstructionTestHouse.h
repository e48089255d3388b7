#pragma once
// A hand-made house and a path through it, shared by the instruction tests
// (InstructionGeneratorTest, PathFactsTest). World frame, +Y up, metres.

#include <vector>

#include "common/Math.h"
#include "sim/Mesh.h"

namespace vln::test {

// ---------------------------------------------------------------------------
// a hand-made house: bedroom and kitchen on the west, a hallway on the east
//
//   z=10 +---------+----+
//        | kitchen |    |
//   z=5  +---------+ hall
//        | bedroom |    |
//   z=0  +---------+----+
//       x=0       x=5  x=7
// ---------------------------------------------------------------------------

inline sim::SemanticObject object(int id, const char* category,
                                  const char* color, int room, Vec3f lo,
                                  Vec3f hi) {
  sim::SemanticObject o;
  o.id = id;
  o.category = category;
  o.color = color;
  o.room = room;
  o.bounds = Eigen::AlignedBox3f(lo, hi);
  return o;
}

inline sim::Room room(int id, const char* type, float x0, float z0, float x1,
                      float z1) {
  sim::Room r;
  r.id = id;
  r.type = type;
  r.footprint = Eigen::AlignedBox2f(Vec2f(x0, z0), Vec2f(x1, z1));
  r.floor_y = 0.0f;
  return r;
}

inline sim::Doorway door(int a, int b, Vec3f center, Vec3f normal) {
  sim::Doorway d;
  d.room_a = a;
  d.room_b = b;
  d.center = center;
  d.width = 1.0f;
  d.normal = normal;
  return d;
}

inline sim::SceneSemantics threeRooms() {
  sim::SceneSemantics s;
  s.rooms = {room(0, "bedroom", 0, 0, 5, 5), room(1, "hallway", 5, 0, 7, 10),
             room(2, "kitchen", 0, 5, 5, 10)};
  s.doors = {door(0, 1, {5.0f, 0.0f, 2.5f}, Vec3f::UnitX()),
             door(1, 2, {5.0f, 0.0f, 7.5f}, Vec3f::UnitX())};
  s.objects = {
      object(10, "bed", "red", 0, {0.5f, 0.0f, 0.3f}, {2.5f, 0.6f, 1.9f}),
      object(11, "lamp", "white", 0, {3.8f, 0.0f, 4.0f}, {4.2f, 1.5f, 4.4f}),
      object(12, "plant", "green", 1, {6.4f, 0.0f, 4.6f}, {6.8f, 1.0f, 5.0f}),
      object(13, "fridge", "white", 2, {0.2f, 0.0f, 8.6f}, {0.9f, 1.8f, 9.3f}),
      object(14, "table", "wooden", 2, {2.0f, 0.0f, 6.2f}, {3.2f, 0.75f, 7.0f}),
      object(15, "chair", "black", 2, {3.4f, 0.0f, 8.4f}, {3.9f, 0.9f, 8.9f}),
      object(16, "chair", "red", 2, {1.5f, 0.0f, 5.4f}, {1.9f, 0.9f, 5.8f}),
  };
  return s;
}

// Bedroom -> hallway -> kitchen, ending beside the fridge.
inline std::vector<Vec3f> bedroomToKitchen() {
  return {{2.0f, 0.0f, 3.2f}, {4.0f, 0.0f, 2.5f}, {5.0f, 0.0f, 2.5f},
          {6.0f, 0.0f, 3.0f}, {6.0f, 0.0f, 7.5f}, {5.0f, 0.0f, 7.5f},
          {2.5f, 0.0f, 7.8f}, {1.5f, 0.0f, 8.6f}};
}

}  // namespace vln::test
