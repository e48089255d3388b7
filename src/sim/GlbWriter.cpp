#include "sim/GlbWriter.h"

#include <nlohmann/json.hpp>

#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "common/Check.h"
#include "common/FileIo.h"
#include "sim/SceneFileLayout.h"

namespace vln::sim {
namespace fs = std::filesystem;
using nlohmann::json;

namespace {

// glTF constants (glTF 2.0 specification, section 5: accessor.componentType,
// bufferView.target, sampler filters and wrap modes)
constexpr int kGlUnsignedByte = 5121;
constexpr int kGlUnsignedInt = 5125;
constexpr int kGlFloat = 5126;
constexpr int kGlArrayBuffer = 34962;
constexpr int kGlElementArrayBuffer = 34963;
constexpr int kGlLinear = 9729;
constexpr int kGlLinearMipmapLinear = 9987;
constexpr int kGlRepeat = 10497;

// Accumulates the BIN chunk and the bufferView/accessor arrays.
class GlbBuffer {
 public:
  // appends raw bytes as a new bufferView (4-byte aligned); returns its index
  int addView(const void* data, size_t bytes, std::optional<int> target) {
    while (bin_.size() % 4 != 0) bin_.push_back('\0');
    json view = {
        {"buffer", 0}, {"byteOffset", bin_.size()}, {"byteLength", bytes}};
    if (target) view["target"] = *target;
    bin_.append(static_cast<const char*>(data), bytes);
    views_.push_back(std::move(view));
    return static_cast<int>(views_.size()) - 1;
  }

  // appends an accessor over a whole bufferView; returns its index
  int addAccessor(int view, int componentType, size_t count,
                  std::string_view type, bool normalized = false,
                  json min = nullptr, json max = nullptr) {
    json accessor = {{"bufferView", view},
                     {"componentType", componentType},
                     {"count", count},
                     {"type", type}};
    if (normalized) accessor["normalized"] = true;
    if (!min.is_null()) accessor["min"] = std::move(min);
    if (!max.is_null()) accessor["max"] = std::move(max);
    accessors_.push_back(std::move(accessor));
    return static_cast<int>(accessors_.size()) - 1;
  }

  std::string& bin() { return bin_; }
  json& views() { return views_; }
  json& accessors() { return accessors_; }

 private:
  std::string bin_;
  json views_ = json::array();
  json accessors_ = json::array();
};

// one glTF primitive: the triangles re-indexed to their own vertex arrays
json writePrimitive(const TriangleMesh& mesh,
                    const std::vector<uint32_t>& triangles, int material,
                    std::vector<uint32_t>& localIndex, GlbBuffer& buffer) {
  std::vector<uint32_t> globalOfLocal;
  std::vector<uint32_t> indices;
  indices.reserve(triangles.size() * 3);
  for (uint32_t t : triangles) {
    for (int k = 0; k < 3; ++k) {
      const uint32_t v = mesh.indices[3 * t + k];
      if (localIndex[v] == UINT32_MAX) {
        localIndex[v] = static_cast<uint32_t>(globalOfLocal.size());
        globalOfLocal.push_back(v);
      }
      indices.push_back(localIndex[v]);
    }
  }
  // reset only what this primitive touched, keeping export O(triangles)
  for (uint32_t v : globalOfLocal) localIndex[v] = UINT32_MAX;

  const size_t count = globalOfLocal.size();
  std::vector<float> positions(count * 3);
  Vec3f lo = Vec3f::Constant(std::numeric_limits<float>::infinity());
  Vec3f hi = -lo;
  for (size_t i = 0; i < count; ++i) {
    const Vec3f& p = mesh.positions[globalOfLocal[i]];
    for (int a = 0; a < 3; ++a) positions[3 * i + a] = p[a];
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  json attributes;
  attributes["POSITION"] = buffer.addAccessor(
      buffer.addView(positions.data(), positions.size() * sizeof(float),
                     kGlArrayBuffer),
      kGlFloat, count, "VEC3", false, {lo.x(), lo.y(), lo.z()},
      {hi.x(), hi.y(), hi.z()});
  if (!mesh.colors.empty()) {
    std::vector<uint8_t> colors(count * 4);
    for (size_t i = 0; i < count; ++i) {
      const Rgb8& c = mesh.colors[globalOfLocal[i]];
      colors[4 * i + 0] = c[0];
      colors[4 * i + 1] = c[1];
      colors[4 * i + 2] = c[2];
      colors[4 * i + 3] = 255;
    }
    attributes["COLOR_0"] = buffer.addAccessor(
        buffer.addView(colors.data(), colors.size(), kGlArrayBuffer),
        kGlUnsignedByte, count, "VEC4", /*normalized=*/true);
  }
  if (!mesh.uvs.empty()) {
    std::vector<float> uvs(count * 2);
    for (size_t i = 0; i < count; ++i) {
      uvs[2 * i + 0] = mesh.uvs[globalOfLocal[i]].x();
      uvs[2 * i + 1] = mesh.uvs[globalOfLocal[i]].y();
    }
    attributes["TEXCOORD_0"] = buffer.addAccessor(
        buffer.addView(uvs.data(), uvs.size() * sizeof(float), kGlArrayBuffer),
        kGlFloat, count, "VEC2");
  }
  json primitive = {
      {"attributes", std::move(attributes)},
      {"indices",
       buffer.addAccessor(
           buffer.addView(indices.data(), indices.size() * sizeof(uint32_t),
                          kGlElementArrayBuffer),
           kGlUnsignedInt, indices.size(), "SCALAR")},
      {"mode", 4}};
  if (material >= 0) primitive["material"] = material;
  return primitive;
}

}  // namespace

void writeGlb(const fs::path& file, const TriangleMesh& input) {
  // materials and textures in order of first use as written (the order in
  // which glTF readers that load lazily, like assimp's, will see them)
  TriangleMesh mesh = input;
  std::vector<uint32_t> emitted;
  for (const auto& [object, byMaterial] : groupTriangles(mesh))
    for (const auto& [material, triangles] : byMaterial)
      emitted.insert(emitted.end(), triangles.begin(), triangles.end());
  keepUsedMaterials(mesh, &emitted);
  GlbBuffer buffer;
  json root;
  root["asset"] = {{"version", "2.0"}, {"generator", "vlnce-cpp"}};

  // materials: unlit so viewers show the baked vertex colours unchanged
  json materials = json::array();
  for (const Material& m : mesh.materials) {
    json pbr = {{"baseColorFactor",
                 {m.base_color[0], m.base_color[1], m.base_color[2], 1.0f}},
                {"metallicFactor", 0.0f},
                {"roughnessFactor", 1.0f}};
    if (m.texture >= 0) pbr["baseColorTexture"] = {{"index", m.texture}};
    materials.push_back(
        {{"name", m.name},
         {"pbrMetallicRoughness", std::move(pbr)},
         {"extensions", {{"KHR_materials_unlit", json::object()}}}});
  }

  // textures: PNG images embedded through bufferViews
  json images = json::array();
  json textures = json::array();
  for (size_t i = 0; i < mesh.textures.size(); ++i) {
    const std::string png = encodePng(mesh.textures[i]);
    const int view = buffer.addView(png.data(), png.size(), std::nullopt);
    images.push_back({{"name", mesh.textures[i].name},
                      {"bufferView", view},
                      {"mimeType", "image/png"}});
    textures.push_back({{"source", i}, {"sampler", 0}});
  }

  // one node (and mesh) per semantic object, the rest in "structure"
  json meshes = json::array();
  json nodes = json::array();
  std::vector<uint32_t> localIndex(mesh.positions.size(), UINT32_MAX);
  for (const auto& [object, byMaterial] : groupTriangles(mesh)) {
    json primitives = json::array();
    for (const auto& [material, triangles] : byMaterial)
      primitives.push_back(
          writePrimitive(mesh, triangles, material, localIndex, buffer));
    const std::string name = groupName(object);
    meshes.push_back({{"name", name}, {"primitives", std::move(primitives)}});
    nodes.push_back({{"name", name}, {"mesh", meshes.size() - 1}});
  }
  json sceneNodes = json::array();
  for (size_t i = 0; i < nodes.size(); ++i) sceneNodes.push_back(i);

  root["scene"] = 0;
  root["scenes"] = json::array({{{"nodes", std::move(sceneNodes)}}});
  root["nodes"] = std::move(nodes);
  root["meshes"] = std::move(meshes);
  if (!materials.empty()) {
    root["materials"] = std::move(materials);
    root["extensionsUsed"] = json::array({"KHR_materials_unlit"});
  }
  if (!images.empty()) {
    root["images"] = std::move(images);
    root["textures"] = std::move(textures);
    root["samplers"] = json::array({{{"magFilter", kGlLinear},
                                     {"minFilter", kGlLinearMipmapLinear},
                                     {"wrapS", kGlRepeat},
                                     {"wrapT", kGlRepeat}}});
  }
  std::string& bin = buffer.bin();
  while (bin.size() % 4 != 0) bin.push_back('\0');
  root["buffers"] = json::array({{{"byteLength", bin.size()}}});
  root["bufferViews"] = std::move(buffer.views());
  root["accessors"] = std::move(buffer.accessors());

  // GLB container: 12-byte header, JSON chunk padded with spaces, BIN chunk
  // padded with zeros (glTF 2.0 specification, section 4.4)
  std::string jsonText = root.dump();
  while (jsonText.size() % 4 != 0) jsonText.push_back(' ');
  std::string out;
  auto put32 = [&out](uint32_t value) {
    for (int shift = 0; shift < 32; shift += 8)
      out.push_back(static_cast<char>((value >> shift) & 0xFF));
  };
  const size_t total = 12 + 8 + jsonText.size() + 8 + bin.size();
  VLN_CHECK_ARG(total <= UINT32_MAX, "saveScene(): ", file,
                " would exceed the 4 GiB limit of a .glb file (", total,
                " bytes)");
  put32(0x46546C67);  // "glTF"
  put32(2);
  put32(static_cast<uint32_t>(total));
  put32(static_cast<uint32_t>(jsonText.size()));
  put32(0x4E4F534A);  // "JSON"
  out += jsonText;
  put32(static_cast<uint32_t>(bin.size()));
  put32(0x004E4942);  // "BIN\0"
  out += bin;
  common::writeFileAtomic(file, out);
}

}  // namespace vln::sim
