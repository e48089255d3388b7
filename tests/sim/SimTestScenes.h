#pragma once
// Small scenes built in code, shared by the sim tests (and NavMeshBench):
// boxes and walls for navmesh geometry, coloured quads for rendered rooms.
// Y up, metres; no GoogleTest here, so benchmarks can include it.

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <utility>

#include "sim/Mesh.h"
#include "sim/Scene.h"

namespace vln::test {

inline constexpr float kWall = 0.12f;    ///< wall thickness, m
inline constexpr float kWallTop = 2.5f;  ///< wall height, m
inline constexpr float kSlab = 0.1f;     ///< floor slab thickness, m

/// Appends an axis-aligned box with outward-facing (counter-clockwise seen
/// from outside) triangles.
inline void addBox(sim::TriangleMesh& mesh, const Vec3f& lo, const Vec3f& hi) {
  const auto base = static_cast<uint32_t>(mesh.positions.size());
  for (int i = 0; i < 8; ++i)
    mesh.positions.emplace_back(i & 1 ? hi.x() : lo.x(),
                                i & 2 ? hi.y() : lo.y(),
                                i & 4 ? hi.z() : lo.z());
  const Vec3f center = (lo + hi) / 2.0f;
  const int quads[6][4] = {{0, 2, 6, 4}, {1, 3, 7, 5}, {0, 1, 5, 4},
                           {2, 3, 7, 6}, {0, 1, 3, 2}, {4, 5, 7, 6}};
  for (const auto& q : quads) {
    const Vec3f& a = mesh.positions[base + q[0]];
    const Vec3f& b = mesh.positions[base + q[1]];
    const Vec3f& c = mesh.positions[base + q[2]];
    const bool outward =
        (b - a).cross(c - a).dot((a + c) / 2.0f - center) > 0.0f;
    const uint32_t i0 = base + q[0], i1 = base + q[1], i2 = base + q[2],
                   i3 = base + q[3];
    if (outward)
      mesh.indices.insert(mesh.indices.end(), {i0, i1, i2, i0, i2, i3});
    else
      mesh.indices.insert(mesh.indices.end(), {i0, i2, i1, i0, i3, i2});
  }
}

/// A wall of thickness kWall from the slab's bottom to kWallTop, centred on
/// x and running from z0 to z1.
inline void wallAlongZ(sim::TriangleMesh& m, float x, float z0, float z1) {
  addBox(m, {x - kWall / 2, -kSlab, z0}, {x + kWall / 2, kWallTop, z1});
}
/// The same centred on z, running from x0 to x1.
inline void wallAlongX(sim::TriangleMesh& m, float z, float x0, float x1) {
  addBox(m, {x0, -kSlab, z - kWall / 2}, {x1, kWallTop, z + kWall / 2});
}

/// Appends a floor slab over x in [0, width], z in [0, depth] (top at
/// y = 0) and the four outer walls around it.
inline void addWalledFloor(sim::TriangleMesh& m, float width, float depth) {
  addBox(m, {0, -kSlab, 0}, {width, 0, depth});
  wallAlongX(m, 0, -kWall, width + kWall);
  wallAlongX(m, depth, -kWall, width + kWall);
  wallAlongZ(m, 0, 0, depth);
  wallAlongZ(m, width, 0, depth);
}

/// The table of roomWithTable(): x and z in [kTableLo, kTableHi], top at
/// kTableTop.
inline constexpr float kTableLo = 2.25f, kTableHi = 3.75f, kTableTop = 0.75f;

/// A walled 6 x 6 m room (x, z in [0, 6]) with a solid 1.5 x 1.5 m table,
/// 0.75 m high, in its middle: two navmesh islands.
inline sim::TriangleMesh roomWithTable() {
  sim::TriangleMesh m;
  addBox(m, {0, -kSlab, 0}, {6, 0, 6});
  addBox(m, {-kWall, -kSlab, -kWall}, {6 + kWall, kWallTop, 0});
  addBox(m, {-kWall, -kSlab, 6}, {6 + kWall, kWallTop, 6 + kWall});
  addBox(m, {-kWall, -kSlab, 0}, {0, kWallTop, 6});
  addBox(m, {6, -kSlab, 0}, {6 + kWall, kWallTop, 6});
  addBox(m, {kTableLo, 0, kTableLo}, {kTableHi, kTableTop, kTableHi});
  return m;
}

/// The issue 19 Z-up glTF room before export: a 10 x 10 m floor slab
/// 0.2 m thick (x, z in [-5, 5], top at y = 0) with a table and two boxes
/// on it, nothing taller than 1 m and no walls.
inline sim::TriangleMesh slabWithFurniture() {
  sim::TriangleMesh m;
  addBox(m, {-5, -0.2f, -5}, {5, 0, 5});
  addBox(m, {1, 0, 1}, {2.5f, 0.75f, 2});
  addBox(m, {-3, 0, -3}, {-2, 1, -2});
  addBox(m, {3, 0, -4}, {4, 0.5f, -3});
  return m;
}

/// Appends the quad corners[0..3] (two triangles 0-1-2 and 0-2-3, facing
/// where the corners run counter-clockwise) in `color`, labelled `object`
/// (-1: none).
inline void addQuad(sim::TriangleMesh& mesh,
                    const std::array<Vec3f, 4>& corners, sim::Rgb8 color,
                    int object) {
  const auto base = static_cast<uint32_t>(mesh.positions.size());
  for (const Vec3f& p : corners) {
    mesh.positions.push_back(p);
    mesh.colors.push_back(color);
  }
  for (uint32_t i : {0u, 1u, 2u, 0u, 2u, 3u}) mesh.indices.push_back(base + i);
  mesh.triangle_object.push_back(object);
  mesh.triangle_object.push_back(object);
}

/// Appends the four inward-facing walls of the box [x0, x1] x [y0, y1] x
/// [z0, z1].
inline void addWalls(sim::TriangleMesh& mesh, float x0, float x1, float z0,
                     float z1, float y0, float y1) {
  const sim::Rgb8 wall{200, 200, 210};
  addQuad(mesh, {Vec3f(x0, y0, z0), {x1, y0, z0}, {x1, y1, z0}, {x0, y1, z0}},
          wall, -1);
  addQuad(mesh, {Vec3f(x1, y0, z1), {x0, y0, z1}, {x0, y1, z1}, {x1, y1, z1}},
          wall, -1);
  addQuad(mesh, {Vec3f(x0, y0, z1), {x0, y0, z0}, {x0, y1, z0}, {x0, y1, z1}},
          wall, -1);
  addQuad(mesh, {Vec3f(x1, y0, z0), {x1, y0, z1}, {x1, y1, z1}, {x1, y1, z0}},
          wall, -1);
}

/// A 6 m x 6 m room, floor y = 0, walls at x, z = +-3 up to 2.7 m (with a
/// ceiling there when `ceiling`), and a red 1 m cube (object 4, a "table",
/// "red") centred at (2, 0.5, 0), as scene `name` with the default navmesh.
inline std::shared_ptr<const sim::Scene> roomWithCube(const std::string& name,
                                                      bool ceiling) {
  sim::TriangleMesh mesh;
  addQuad(mesh, {Vec3f(-3, 0, 3), {3, 0, 3}, {3, 0, -3}, {-3, 0, -3}},
          sim::Rgb8{180, 160, 120}, -1);
  if (ceiling)
    addQuad(mesh,
            {Vec3f(-3, 2.7f, -3), {3, 2.7f, -3}, {3, 2.7f, 3}, {-3, 2.7f, 3}},
            sim::Rgb8{200, 200, 210}, -1);
  addWalls(mesh, -3, 3, -3, 3, 0, 2.7f);
  // the cube, faces outward
  const float x0 = 1.5f, x1 = 2.5f, y1 = 1.0f, z0 = -0.5f, z1 = 0.5f;
  const sim::Rgb8 red{220, 30, 30};
  addQuad(mesh, {Vec3f(x0, 0, z1), {x1, 0, z1}, {x1, y1, z1}, {x0, y1, z1}},
          red, 4);
  addQuad(mesh, {Vec3f(x1, 0, z0), {x0, 0, z0}, {x0, y1, z0}, {x1, y1, z0}},
          red, 4);
  addQuad(mesh, {Vec3f(x0, 0, z0), {x0, 0, z1}, {x0, y1, z1}, {x0, y1, z0}},
          red, 4);
  addQuad(mesh, {Vec3f(x1, 0, z1), {x1, 0, z0}, {x1, y1, z0}, {x1, y1, z1}},
          red, 4);
  addQuad(mesh, {Vec3f(x0, y1, z1), {x1, y1, z1}, {x1, y1, z0}, {x0, y1, z0}},
          red, 4);
  sim::SceneSemantics semantics;
  sim::SemanticObject cube;
  cube.id = 4;
  cube.category = "table";
  cube.color = "red";
  cube.bounds = Eigen::AlignedBox3f(Vec3f(x0, 0, z0), Vec3f(x1, y1, z1));
  semantics.objects.push_back(cube);
  return sim::Scene::fromMesh(name, std::move(mesh), std::move(semantics),
                              sim::NavMeshConfig{});
}

}  // namespace vln::test
