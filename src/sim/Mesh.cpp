#include "sim/Mesh.h"

#include <cmath>

#include "common/Check.h"

namespace vln::sim {

Eigen::AlignedBox3f TriangleMesh::bounds() const {
  Eigen::AlignedBox3f box;
  for (const auto& p : positions) box.extend(p);
  return box;
}

void TriangleMesh::append(const TriangleMesh& other) {
  const auto vertexOffset = static_cast<uint32_t>(positions.size());
  const auto materialOffset = static_cast<int32_t>(materials.size());
  const auto textureOffset = static_cast<int>(textures.size());
  const size_t oldVertices = positions.size();
  const size_t oldTriangles = triangleCount();

  // optional per-vertex arrays: pad whichever side lacks them
  if (!other.colors.empty() && colors.empty() && oldVertices > 0)
    colors.assign(oldVertices, Rgb8{255, 255, 255});
  if (!other.uvs.empty() && uvs.empty() && oldVertices > 0)
    uvs.assign(oldVertices, Vec2f::Zero());
  positions.insert(positions.end(), other.positions.begin(),
                   other.positions.end());
  if (!colors.empty()) {
    if (other.colors.empty())
      colors.resize(positions.size(), Rgb8{255, 255, 255});
    else
      colors.insert(colors.end(), other.colors.begin(), other.colors.end());
  }
  if (!uvs.empty()) {
    if (other.uvs.empty())
      uvs.resize(positions.size(), Vec2f::Zero());
    else
      uvs.insert(uvs.end(), other.uvs.begin(), other.uvs.end());
  }

  for (uint32_t index : other.indices) indices.push_back(index + vertexOffset);

  // optional per-triangle arrays
  if (!other.triangle_material.empty() && triangle_material.empty() &&
      oldTriangles > 0)
    triangle_material.assign(oldTriangles, -1);
  if (!triangle_material.empty()) {
    if (other.triangle_material.empty()) {
      triangle_material.resize(triangleCount(), -1);
    } else {
      for (int32_t m : other.triangle_material)
        triangle_material.push_back(m < 0 ? -1 : m + materialOffset);
    }
  }
  if (!other.triangle_object.empty() && triangle_object.empty() &&
      oldTriangles > 0)
    triangle_object.assign(oldTriangles, -1);
  if (!triangle_object.empty()) {
    if (other.triangle_object.empty())
      triangle_object.resize(triangleCount(), -1);
    else
      triangle_object.insert(triangle_object.end(),
                             other.triangle_object.begin(),
                             other.triangle_object.end());
  }

  for (Material m : other.materials) {
    if (m.texture >= 0) m.texture += textureOffset;
    materials.push_back(std::move(m));
  }
  textures.insert(textures.end(), other.textures.begin(), other.textures.end());
}

void TriangleMesh::validate(std::string_view source) const {
  VLN_CHECK_ARG(!indices.empty(), source, ": mesh has no triangles");
  VLN_CHECK_ARG(indices.size() % 3 == 0, source, ": index count ",
                indices.size(), " is not a multiple of 3");
  VLN_CHECK_ARG(colors.empty() || colors.size() == positions.size(), source,
                ": ", colors.size(), " vertex colours for ", positions.size(),
                " vertices");
  VLN_CHECK_ARG(uvs.empty() || uvs.size() == positions.size(), source, ": ",
                uvs.size(), " texture coordinates for ", positions.size(),
                " vertices");
  VLN_CHECK_ARG(triangle_material.empty() ||
                    triangle_material.size() == triangleCount(),
                source, ": ", triangle_material.size(),
                " triangle materials for ", triangleCount(), " triangles");
  VLN_CHECK_ARG(triangle_object.empty() ||
                    triangle_object.size() == triangleCount(),
                source, ": ", triangle_object.size(), " triangle objects for ",
                triangleCount(), " triangles");
  for (size_t i = 0; i < positions.size(); ++i)
    VLN_CHECK_ARG(positions[i].allFinite(), source, ": vertex ", i,
                  " has a non-finite coordinate");
  for (size_t i = 0; i < indices.size(); ++i)
    VLN_CHECK_ARG(indices[i] < positions.size(), source, ": index ", i,
                  " refers to vertex ", indices[i], " of ", positions.size());
  for (size_t i = 0; i < triangle_material.size(); ++i)
    VLN_CHECK_ARG(triangle_material[i] < static_cast<int>(materials.size()),
                  source, ": triangle ", i, " uses material ",
                  triangle_material[i], " of ", materials.size());
  for (size_t i = 0; i < materials.size(); ++i) {
    const Material& m = materials[i];
    VLN_CHECK_ARG(m.texture < static_cast<int>(textures.size()), source,
                  ": material '", m.name, "' uses texture ", m.texture, " of ",
                  textures.size());
  }
  for (const Texture& t : textures)
    VLN_CHECK_ARG(t.width > 0 && t.height > 0 &&
                      t.rgb.size() == static_cast<size_t>(t.width) *
                                          static_cast<size_t>(t.height) * 3,
                  source, ": texture '", t.name, "' has ", t.rgb.size(),
                  " bytes for ", t.width, "x", t.height);
}

int SceneSemantics::roomAt(const Vec3f& p) const {
  // rooms on other floors are ignored: the point must be within the storey
  // height above the room's floor
  constexpr float kStoreyHeight = 2.5f;
  for (size_t i = 0; i < rooms.size(); ++i) {
    const Room& room = rooms[i];
    if (p.y() < room.floor_y - 0.5f || p.y() > room.floor_y + kStoreyHeight)
      continue;
    if (room.footprint.contains(Vec2f(p.x(), p.z())))
      return static_cast<int>(i);
  }
  return -1;
}

const SemanticObject* SceneSemantics::object(int id) const {
  for (const auto& o : objects)
    if (o.id == id) return &o;
  return nullptr;
}

}  // namespace vln::sim
