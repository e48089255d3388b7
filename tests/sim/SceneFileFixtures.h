#pragma once
// Scenes and checks shared by the scene-file tests (MeshIoTest,
// MeshImportTest, GlbWriterTest, ObjWriterTest, SceneSemanticsFileTest).

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdint>
#include <initializer_list>
#include <stdexcept>
#include <string>

#include "sim/Mesh.h"

namespace vln::test {

/// A 4x2 texture whose every texel differs, so flips and transposes show.
inline sim::Texture checkerTexture(const std::string& name) {
  sim::Texture t;
  t.name = name;
  t.width = 4;
  t.height = 2;
  for (int y = 0; y < t.height; ++y)
    for (int x = 0; x < t.width; ++x)
      for (int c = 0; c < 3; ++c)
        t.rgb.push_back(static_cast<uint8_t>(30 * x + 100 * y + 7 * c));
  return t;
}

/// Two objects (a coloured box face pair, a textured quad) plus untagged,
/// material-less structure: every feature the exporters must carry.
inline sim::TriangleMesh featureMesh() {
  sim::TriangleMesh mesh;
  mesh.materials = {{"painted", {0.25f, 0.5f, 1.0f}, -1},
                    {"wood", {1.0f, 1.0f, 1.0f}, 0}};
  mesh.textures = {checkerTexture("planks")};
  auto quad = [&](Vec3f a, Vec3f b, Vec3f c, Vec3f d, sim::Rgb8 color,
                  int material, int object) {
    const auto base = static_cast<uint32_t>(mesh.positions.size());
    const Vec3f corners[4] = {a, b, c, d};
    const Vec2f uvs[4] = {
        {0.0f, 0.0f}, {1.5f, 0.0f}, {1.5f, 0.75f}, {0.0f, 0.75f}};
    for (int i = 0; i < 4; ++i) {
      mesh.positions.push_back(corners[i]);
      mesh.colors.push_back(
          {color[0], static_cast<uint8_t>(color[1] + 10 * i), color[2]});
      mesh.uvs.push_back(uvs[i]);
    }
    for (uint32_t i : {0u, 1u, 2u, 0u, 2u, 3u})
      mesh.indices.push_back(base + i);
    for (int i = 0; i < 2; ++i) {
      mesh.triangle_material.push_back(material);
      mesh.triangle_object.push_back(object);
    }
  };
  quad({0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {200, 10, 30}, 0, 3);
  quad({0, 0, 0}, {0, 1, 0}, {0, 1, 1}, {0, 0, 1}, {10, 200, 30}, 0, 3);
  quad({2, 0, 2}, {3.25f, 0, 2}, {3.25f, 0.125f, 3.5f}, {2, 0.125f, 3.5f},
       {255, 128, 0}, 1, 12);
  quad({-1, 0, -1}, {4, 0, -1}, {4, 0, 4}, {-1, 0, 4}, {90, 90, 90}, -1, -1);
  return mesh;
}

/// Two rooms, a door between them and the two objects of featureMesh().
inline sim::SceneSemantics featureSemantics() {
  sim::SceneSemantics s;
  sim::Room room;
  room.id = 0;
  room.type = "living room";
  room.footprint = Eigen::AlignedBox2f(Vec2f(-1, -1), Vec2f(4, 4));
  s.rooms.push_back(room);
  room.id = 1;
  room.type = "kitchen";
  room.footprint = Eigen::AlignedBox2f(Vec2f(4, -1), Vec2f(7, 4));
  s.rooms.push_back(room);
  sim::Doorway door;
  door.room_a = 0;
  door.room_b = 1;
  door.center = Vec3f(4, 0, 1.5f);
  door.width = 0.9f;
  door.normal = Vec3f(1, 0, 0);
  s.doors.push_back(door);
  sim::SemanticObject object;
  object.id = 3;
  object.category = "cabinet";
  object.color = "blue";
  object.room = 0;
  object.bounds = Eigen::AlignedBox3f(Vec3f(0, 0, 0), Vec3f(1, 1, 1));
  s.objects.push_back(object);
  object.id = 12;
  object.category = "rug";
  object.color = "orange";
  object.bounds =
      Eigen::AlignedBox3f(Vec3f(2, 0, 2), Vec3f(3.25f, 0.125f, 3.5f));
  s.objects.push_back(object);
  return s;
}

/// Expects `body` to throw exception type E whose message contains every
/// string in `parts`.
template <class E, class F>
void expectThrowWith(F body, std::initializer_list<std::string> parts) {
  try {
    body();
    ADD_FAILURE() << "expected an exception";
  } catch (const E& e) {
    for (const std::string& part : parts)
      EXPECT_THAT(e.what(), ::testing::HasSubstr(part));
  } catch (const std::exception& e) {
    ADD_FAILURE() << "wrong exception type: " << e.what();
  }
}

}  // namespace vln::test
