#pragma once
// Triangle meshes and the semantic annotations kept beside them. All
// positions are world frame: +Y up, metres (see common/Math.h).

#include <Eigen/Geometry>

#include <array>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "common/Math.h"

namespace vln::sim {

/// 8-bit RGB colour.
using Rgb8 = std::array<uint8_t, 3>;

/// An RGB8 image used as a material texture.
struct Texture {
  std::string name;
  int width = 0;
  int height = 0;
  /// width*height*3 bytes, row-major, first row = v=0 (glTF/assimp layout).
  std::vector<uint8_t> rgb;
  bool operator==(const Texture&) const = default;
};

/// Unlit material: colour = base_color * vertex colour * texture(uv).
struct Material {
  std::string name;
  std::array<float, 3> base_color{1.0f, 1.0f, 1.0f};
  /// Index into TriangleMesh::textures, or -1.
  int texture = -1;
  bool operator==(const Material&) const = default;
};

/// Indexed triangle mesh with per-vertex colour (lighting baked in) and
/// optional UVs, per-triangle material and semantic object ids.
struct TriangleMesh {
  std::vector<Vec3f> positions;
  /// Per vertex, or empty (white).
  std::vector<Rgb8> colors;
  /// Per vertex, or empty (untextured).
  std::vector<Vec2f> uvs;
  /// Three vertex indices per triangle, counter-clockwise seen from the front.
  std::vector<uint32_t> indices;
  /// Per triangle index into materials, or empty (no materials).
  std::vector<int32_t> triangle_material;
  /// Per triangle semantic object id (SceneSemantics::objects[i].id) or -1;
  /// empty when the scene has no semantics.
  std::vector<int32_t> triangle_object;
  std::vector<Material> materials;
  std::vector<Texture> textures;

  /// Number of triangles (indices.size() / 3).
  size_t triangleCount() const { return indices.size() / 3; }
  /// Axis-aligned bounds of all vertices (empty box for an empty mesh).
  Eigen::AlignedBox3f bounds() const;
  /// Appends `other`, offsetting its indices, materials and textures; the
  /// optional per-vertex/per-triangle arrays are filled with defaults where
  /// only one side has them.
  void append(const TriangleMesh& other);
  /// Throws std::invalid_argument naming `source` when array sizes disagree,
  /// an index is out of range, a coordinate is not finite, or the mesh has no
  /// triangles.
  void validate(std::string_view source) const;
  bool operator==(const TriangleMesh&) const = default;
};

/// A room of a procedural house: an axis-aligned footprint on one floor.
struct Room {
  int id = -1;
  /// "bedroom", "kitchen", "bathroom", "living room", "hallway", "office",
  /// "dining room", ...
  std::string type;
  /// Footprint in the horizontal plane: min/max of (x, z), metres.
  Eigen::AlignedBox2f footprint;
  /// Height of the walkable floor (y), metres.
  float floor_y = 0.0f;
  bool operator==(const Room& o) const {
    return id == o.id && type == o.type && footprint.isApprox(o.footprint) &&
           floor_y == o.floor_y;
  }
};

/// An opening in a wall between two rooms (or a room and the outside: -1).
struct Doorway {
  int room_a = -1;
  int room_b = -1;
  /// Centre of the opening at floor height.
  Vec3f center = Vec3f::Zero();
  /// Clear width, metres.
  float width = 0.0f;
  /// Unit normal of the wall plane (horizontal).
  Vec3f normal = Vec3f::UnitX();
  bool operator==(const Doorway&) const = default;
};

/// A furniture landmark with a semantic label.
struct SemanticObject {
  int id = -1;
  /// "bed", "sofa", "table", "chair", "plant", "lamp", "fridge", "tv", ...
  std::string category;
  /// Colour name as an instruction would say it: "red", "white", "wooden", ...
  std::string color;
  /// Room the object stands in, or -1.
  int room = -1;
  Eigen::AlignedBox3f bounds;
  bool operator==(const SemanticObject& o) const {
    return id == o.id && category == o.category && color == o.color &&
           room == o.room && bounds.isApprox(o.bounds);
  }
};

/// Everything known about a scene beyond its triangles. Empty for meshes
/// without annotations (e.g. a bare MP3D .glb).
struct SceneSemantics {
  std::vector<Room> rooms;
  std::vector<Doorway> doors;
  std::vector<SemanticObject> objects;

  /// Index into rooms of the room whose footprint contains (p.x, p.z) at
  /// p.y's floor, or -1.
  int roomAt(const Vec3f& p) const;
  /// The object with this id, or nullptr.
  const SemanticObject* object(int id) const;
  bool empty() const { return rooms.empty() && objects.empty(); }
  bool operator==(const SceneSemantics&) const = default;
};

}  // namespace vln::sim
