#include "world/CaptureDifferences.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <random>
#include <utility>
#include <vector>

#include "common/Random.h"
#include "world/HouseGenerator.h"
#include "world/NavGraphBuilder.h"
#include "world/WorldConfig.h"

namespace vln::world {

namespace {

// A closed door leaf fills the opening up to the generator's door top
// (2.1 m, or 15 cm under the ceiling) and is this thick.
constexpr float kDoorLeafThickness = 0.04f;
constexpr float kDoorTop = 2.1f;
constexpr float kDoorTopBelowCeiling = 0.15f;
// Movable objects: standing, at most this footprint (m^2) and height (m).
constexpr float kMovableMaxArea = 0.5f;
constexpr float kMovableMaxHeight = 1.3f;

Vec3f horizontal(const Vec3f& v) { return {v.x(), 0.0f, v.z()}; }

// Appends an oriented box (8 corners, 12 outward-facing triangles) with one
// vertex colour.
void appendBox(sim::TriangleMesh& mesh, const Vec3f& center, const Vec3f& axisU,
               const Vec3f& axisV, float halfU, float halfV, float y0, float y1,
               const sim::Rgb8& color) {
  // corners: bit 0 = +u, bit 1 = +v, bit 2 = top
  std::array<Vec3f, 8> corner;
  for (int k = 0; k < 8; ++k) {
    const Vec3f horizontalPart = center + ((k & 1) ? halfU : -halfU) * axisU +
                                 ((k & 2) ? halfV : -halfV) * axisV;
    corner[static_cast<size_t>(k)] =
        Vec3f(horizontalPart.x(), (k & 4) ? y1 : y0, horizontalPart.z());
  }
  const auto base = static_cast<uint32_t>(mesh.positions.size());
  for (const Vec3f& c : corner) mesh.positions.push_back(c);
  const bool hadColors = !mesh.colors.empty() || base == 0;
  if (hadColors) mesh.colors.resize(mesh.positions.size(), color);
  if (!mesh.uvs.empty()) mesh.uvs.resize(mesh.positions.size(), Vec2f::Zero());
  static constexpr std::array<std::array<uint32_t, 4>, 6> kFaces = {{
      {0, 1, 3, 2},  // bottom
      {4, 6, 7, 5},  // top
      {0, 4, 5, 1},  // -v
      {2, 3, 7, 6},  // +v
      {0, 2, 6, 4},  // -u
      {1, 5, 7, 3},  // +u
  }};
  for (const auto& f : kFaces) {
    for (const uint32_t i : {f[0], f[1], f[2], f[0], f[2], f[3]})
      mesh.indices.push_back(base + i);
    for (int t = 0; t < 2; ++t) {
      if (!mesh.triangle_material.empty()) mesh.triangle_material.push_back(-1);
      if (!mesh.triangle_object.empty()) mesh.triangle_object.push_back(-1);
    }
  }
  // the winding above faces outward when u x v points down; mirror it
  // otherwise
  if (axisU.cross(axisV).y() < 0.0f) return;
  for (size_t i = mesh.indices.size() - 36; i < mesh.indices.size(); i += 3)
    std::swap(mesh.indices[i + 1], mesh.indices[i + 2]);
}

// Copies the triangles of `object` translated by `offset` as a new semantic
// object; returns false when the object has no triangles.
bool duplicateObject(House& house, const sim::SemanticObject& object,
                     const Vec3f& offset, int room) {
  sim::TriangleMesh& mesh = house.mesh;
  if (mesh.triangle_object.empty()) return false;
  int newId = 0;
  for (const auto& o : house.semantics.objects)
    newId = std::max(newId, o.id + 1);
  const size_t triangles = mesh.triangleCount();
  bool copied = false;
  for (size_t t = 0; t < triangles; ++t) {
    if (mesh.triangle_object[t] != object.id) continue;
    copied = true;
    for (int k = 0; k < 3; ++k) {
      const uint32_t v = mesh.indices[3 * t + static_cast<size_t>(k)];
      mesh.indices.push_back(static_cast<uint32_t>(mesh.positions.size()));
      mesh.positions.push_back(mesh.positions[v] + offset);
      if (!mesh.colors.empty()) mesh.colors.push_back(mesh.colors[v]);
      if (!mesh.uvs.empty()) mesh.uvs.push_back(mesh.uvs[v]);
    }
    if (!mesh.triangle_material.empty())
      mesh.triangle_material.push_back(mesh.triangle_material[t]);
    mesh.triangle_object.push_back(newId);
  }
  if (!copied) return false;
  sim::SemanticObject moved = object;
  moved.id = newId;
  moved.room = room;
  moved.bounds.translate(offset);
  house.semantics.objects.push_back(moved);
  return true;
}

}  // namespace

CaptureDifferences applyCaptureDifferences(House& house,
                                           const BuiltNavGraph& built,
                                           const WorldConfig& config,
                                           uint64_t seed) {
  CaptureDifferences made;
  const ReconstructionConfig& rc = config.reconstruction;
  std::mt19937_64 rng(seed);

  // closed doors: a leaf in the opening
  const float top =
      std::min(kDoorTop, config.house.wall_height - kDoorTopBelowCeiling);
  const std::vector<sim::Doorway> doors = house.semantics.doors;
  for (const sim::Doorway& door : doors) {
    const bool close = common::bernoulli(rng, rc.closed_door_probability);
    if (!close || door.room_a < 0 || door.room_b < 0) continue;
    const Vec3f normal = horizontal(door.normal).normalized();
    const Vec3f along(normal.z(), 0.0f, -normal.x());
    appendBox(house.mesh, door.center, along, normal, 0.5f * door.width,
              0.5f * kDoorLeafThickness, door.center.y(), door.center.y() + top,
              sim::Rgb8{124, 86, 52});
    ++made.closed_doors;
  }

  // moved objects: a copy of a movable object on top of a node
  const auto& objects = house.semantics.objects;
  std::vector<int> movable;
  for (size_t i = 0; i < objects.size(); ++i) {
    const auto& o = objects[i];
    const Vec3f size = o.bounds.sizes();
    const int room = o.room;
    const float floorY =
        room >= 0 ? house.semantics.rooms[static_cast<size_t>(room)].floor_y
                  : 0.0f;
    if (o.bounds.min().y() < floorY + 0.05f && size.y() > 0.3f &&
        size.y() <= kMovableMaxHeight && size.x() * size.z() <= kMovableMaxArea)
      movable.push_back(static_cast<int>(i));
  }
  if (movable.empty()) return made;
  for (int n = 0; n < built.graph.numNodes(); ++n) {
    if (!common::bernoulli(rng, rc.moved_object_probability)) continue;
    const int room = built.room[static_cast<size_t>(n)];
    std::vector<int> choices;
    for (const int i : movable)
      if (objects[static_cast<size_t>(i)].room == room) choices.push_back(i);
    if (choices.empty()) choices = movable;
    const sim::SemanticObject object =
        objects[static_cast<size_t>(choices[static_cast<size_t>(
            common::uniformIndex(rng, static_cast<int>(choices.size())))])];
    const Vec3f node = built.graph.node(n).position;
    const float angle = common::uniformRange(rng, -kPi, kPi);
    const float radius = rc.moved_object_offset *
                         static_cast<float>(std::sqrt(common::uniform01(rng)));
    const Vec3f target(node.x() + radius * std::cos(angle), 0.0f,
                       node.z() + radius * std::sin(angle));
    const Vec3f center = object.bounds.center();
    const Vec3f offset(target.x() - center.x(), 0.0f, target.z() - center.z());

    // it must stand inside the room, clear of the walls and other furniture
    if (room < 0) continue;
    const sim::Room& r = house.semantics.rooms[static_cast<size_t>(room)];
    Eigen::AlignedBox3f placed = object.bounds;
    placed.translate(offset);
    const float inset = 0.5f * config.house.wall_thickness + 0.02f;
    const bool inside = placed.min().x() >= r.footprint.min().x() + inset &&
                        placed.max().x() <= r.footprint.max().x() - inset &&
                        placed.min().z() >= r.footprint.min().y() + inset &&
                        placed.max().z() <= r.footprint.max().y() - inset;
    bool overlaps = false;
    for (const auto& o : house.semantics.objects) {
      if (o.bounds.sizes().y() < 0.05f) continue;  // rugs lie under things
      const Eigen::AlignedBox3f both = o.bounds.intersection(placed);
      if (!both.isEmpty() && both.sizes().x() > 0.0f && both.sizes().z() > 0.0f)
        overlaps = true;
    }
    if (!inside || overlaps) continue;
    if (duplicateObject(house, object, offset, room)) ++made.moved_objects;
  }
  return made;
}

}  // namespace vln::world
