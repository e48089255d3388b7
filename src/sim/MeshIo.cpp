#include "sim/MeshIo.h"

#include <assimp/config.h>
#include <assimp/material.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <assimp/Importer.hpp>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstring>
#include <fstream>
#include <map>
#include <optional>
#include <set>
#include <string_view>
#include <unordered_map>

#include "common/Check.h"
#include "common/FileIo.h"
#include "common/Json.h"
#include "sim/PlyCheck.h"

namespace vln::sim {
namespace fs = std::filesystem;
using nlohmann::json;

namespace {

// ===========================================================================
// shared helpers
// ===========================================================================

constexpr std::string_view kObjectPrefix = "object_";
constexpr std::string_view kStructureNode = "structure";

std::string lowerExtension(const fs::path& file) {
  std::string ext = file.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) {
    return static_cast<char>(std::tolower(c));
  });
  return ext;
}

// "object_<id>" -> id; anything else (including "object_12a") -> nullopt
std::optional<int> parseObjectName(std::string_view name) {
  if (name.substr(0, kObjectPrefix.size()) != kObjectPrefix)
    return std::nullopt;
  std::string_view digits = name.substr(kObjectPrefix.size());
  if (digits.empty()) return std::nullopt;
  int id = 0;
  auto [end, ec] =
      std::from_chars(digits.data(), digits.data() + digits.size(), id);
  if (ec != std::errc() || end != digits.data() + digits.size() || id < 0)
    return std::nullopt;
  return id;
}

uint8_t unitToByte(float value) {
  // rounding (not truncation) makes byte -> float -> byte exact
  const float clamped = std::clamp(value, 0.0f, 1.0f);
  return static_cast<uint8_t>(std::lround(clamped * 255.0f));
}

// RGB8 texture -> PNG bytes
std::string encodePng(const Texture& texture) {
  cv::Mat rgb(texture.height, texture.width, CV_8UC3,
              const_cast<uint8_t*>(texture.rgb.data()));
  cv::Mat bgr;
  cv::cvtColor(rgb, bgr, cv::COLOR_RGB2BGR);
  std::vector<uint8_t> png;
  VLN_CHECK_IO(cv::imencode(".png", bgr, png),
               "saveScene(): could not encode texture '", texture.name,
               "' as PNG");
  return std::string(png.begin(), png.end());
}

// a decoded BGR image -> RGB8 texture
Texture textureFromBgr(const cv::Mat& bgr, std::string name) {
  cv::Mat rgb;
  cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
  Texture texture;
  texture.name = std::move(name);
  texture.width = rgb.cols;
  texture.height = rgb.rows;
  texture.rgb.resize(static_cast<size_t>(rgb.cols) * rgb.rows * 3);
  for (int row = 0; row < rgb.rows; ++row)
    std::memcpy(texture.rgb.data() + static_cast<size_t>(row) * rgb.cols * 3,
                rgb.ptr<uint8_t>(row), static_cast<size_t>(rgb.cols) * 3);
  return texture;
}

// shortest text that parses back to the same float
std::string floatText(float value) {
  char buffer[32];
  auto [end, ec] = std::to_chars(buffer, buffer + sizeof(buffer), value);
  VLN_ASSERT(ec == std::errc());
  return std::string(buffer, end);
}

// Triangles of a mesh grouped the way both exporters lay them out: one group
// per semantic object (-1 = structure), inside it one run per material.
using TriangleGroups = std::map<int, std::map<int, std::vector<uint32_t>>>;

TriangleGroups groupTriangles(const TriangleMesh& mesh) {
  TriangleGroups groups;
  for (uint32_t t = 0; t < mesh.triangleCount(); ++t) {
    const int object =
        mesh.triangle_object.empty() ? -1 : mesh.triangle_object[t];
    const int material =
        mesh.triangle_material.empty() ? -1 : mesh.triangle_material[t];
    groups[object < 0 ? -1 : object][material < 0 ? -1 : material].push_back(t);
  }
  return groups;
}

std::string groupName(int object) {
  return object < 0 ? std::string(kStructureNode)
                    : strCat(kObjectPrefix, object);
}

// Renumbers materials in order of first use by triangles (in `order`, or
// the mesh's own order) and drops unused ones; then the same for textures
// in order of first use by the kept materials.
void keepUsedMaterials(TriangleMesh& mesh,
                       const std::vector<uint32_t>* order = nullptr) {
  std::vector<int> newMaterial(mesh.materials.size(), -1);
  std::vector<Material> materials;
  auto visit = [&](uint32_t t) {
    const int m =
        mesh.triangle_material.empty() ? -1 : mesh.triangle_material[t];
    if (m >= 0 && newMaterial[m] < 0) {
      newMaterial[m] = static_cast<int>(materials.size());
      materials.push_back(mesh.materials[m]);
    }
  };
  if (order)
    for (uint32_t t : *order) visit(t);
  else
    for (uint32_t t = 0; t < mesh.triangle_material.size(); ++t) visit(t);
  for (int32_t& m : mesh.triangle_material)
    if (m >= 0) m = newMaterial[m];
  std::vector<int> newTexture(mesh.textures.size(), -1);
  std::vector<Texture> textures;
  for (Material& m : materials) {
    if (m.texture < 0) continue;
    if (newTexture[m.texture] < 0) {
      newTexture[m.texture] = static_cast<int>(textures.size());
      textures.push_back(mesh.textures[m.texture]);
    }
    m.texture = newTexture[m.texture];
  }
  mesh.materials = std::move(materials);
  mesh.textures = std::move(textures);
}

// ===========================================================================
// binary glTF 2.0 export
// ===========================================================================

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

// ===========================================================================
// Wavefront OBJ export
// ===========================================================================

// OBJ/MTL names end at whitespace
std::string objName(const std::string& name, std::string_view fallback) {
  if (name.empty()) return std::string(fallback);
  std::string out = name;
  for (char& c : out)
    if (std::isspace(static_cast<unsigned char>(c))) c = '_';
  return out;
}

// texture file names carry the scene stem so that two scenes saved into one
// directory never overwrite each other's images; loading strips it again
std::string textureFileName(const fs::path& objFile, const Texture& texture,
                            size_t index) {
  return strCat(objFile.stem().string(), "_",
                objName(texture.name, strCat("texture_", index)), ".png");
}

void writeObj(const fs::path& file, const TriangleMesh& mesh) {
  const fs::path dir = file.parent_path();
  const std::string mtlName = file.stem().string() + ".mtl";

  // material library and textures
  std::set<std::string> usedMaterialNames;
  std::vector<std::string> materialNames;
  for (size_t i = 0; i < mesh.materials.size(); ++i) {
    std::string name = objName(mesh.materials[i].name, strCat("material_", i));
    VLN_CHECK_ARG(name != AI_DEFAULT_MATERIAL_NAME, "saveScene(): ", file,
                  ": material name '", name,
                  "' is reserved for triangles without a material");
    VLN_CHECK_ARG(usedMaterialNames.insert(name).second, "saveScene(): ", file,
                  ": two materials are both named '", name, "'");
    materialNames.push_back(std::move(name));
  }
  std::set<std::string> usedTextureFiles;
  std::vector<std::string> textureFiles;
  for (size_t i = 0; i < mesh.textures.size(); ++i) {
    std::string name = textureFileName(file, mesh.textures[i], i);
    VLN_CHECK_ARG(usedTextureFiles.insert(name).second, "saveScene(): ", file,
                  ": two textures are both named '", mesh.textures[i].name,
                  "'");
    textureFiles.push_back(std::move(name));
  }
  std::string mtl =
      "# vlnce-cpp material library (unlit: colour = Kd x "
      "vertex colour x map_Kd)\n";
  for (size_t i = 0; i < mesh.materials.size(); ++i) {
    const Material& m = mesh.materials[i];
    mtl += strCat("newmtl ", materialNames[i], "\n");
    mtl += strCat("Kd ", floatText(m.base_color[0]), " ",
                  floatText(m.base_color[1]), " ", floatText(m.base_color[2]),
                  "\n");
    mtl += "illum 0\n";
    if (m.texture >= 0) mtl += strCat("map_Kd ", textureFiles[m.texture], "\n");
    mtl += "\n";
  }

  // vertices once, then faces grouped by object and material; appended
  // with to_chars (streams would dominate the export time of large scans)
  std::string obj = strCat("# vlnce-cpp scene\nmtllib ", mtlName, "\n");
  obj.reserve(mesh.positions.size() * 64 + mesh.indices.size() * 12);
  auto appendFloat = [&obj](float value) {
    char buffer[32];
    auto [end, ec] = std::to_chars(buffer, buffer + sizeof(buffer), value);
    VLN_ASSERT(ec == std::errc());
    obj.push_back(' ');
    obj.append(buffer, end);
  };
  auto appendIndex = [&obj](uint32_t value) {
    char buffer[16];
    auto [end, ec] = std::to_chars(buffer, buffer + sizeof(buffer), value);
    VLN_ASSERT(ec == std::errc());
    obj.append(buffer, end);
  };
  for (size_t i = 0; i < mesh.positions.size(); ++i) {
    const Vec3f& p = mesh.positions[i];
    obj += "v";
    appendFloat(p.x());
    appendFloat(p.y());
    appendFloat(p.z());
    if (!mesh.colors.empty())
      for (int k = 0; k < 3; ++k)
        appendFloat(static_cast<float>(mesh.colors[i][k]) / 255.0f);
    obj += "\n";
  }
  // OBJ puts v = 0 at the bottom of the image; our uvs follow glTF (top)
  for (const Vec2f& uv : mesh.uvs) {
    obj += "vt";
    appendFloat(uv.x());
    appendFloat(1.0f - uv.y());
    obj += "\n";
  }
  const bool withUv = !mesh.uvs.empty();
  for (const auto& [object, byMaterial] : groupTriangles(mesh)) {
    obj += strCat("o ", groupName(object), "\n");
    for (const auto& [material, triangles] : byMaterial) {
      // an explicit default keeps a previous group's material from leaking in
      obj += strCat("usemtl ",
                    material < 0 ? std::string(AI_DEFAULT_MATERIAL_NAME)
                                 : materialNames[material],
                    "\n");
      for (uint32_t t : triangles) {
        obj += "f";
        for (int k = 0; k < 3; ++k) {
          const uint32_t v = mesh.indices[3 * t + k] + 1;
          obj += ' ';
          appendIndex(v);
          if (withUv) {
            obj += '/';
            appendIndex(v);
          }
        }
        obj += "\n";
      }
    }
  }

  for (size_t i = 0; i < mesh.textures.size(); ++i)
    common::writeFileAtomic(dir / textureFiles[i], encodePng(mesh.textures[i]));
  common::writeFileAtomic(dir / mtlName, mtl);
  common::writeFileAtomic(file, obj);
}

// ===========================================================================
// import through assimp
// ===========================================================================

class SceneImporter {
 public:
  SceneImporter(const fs::path& file, const aiScene& scene,
                const MeshLoadConfig& config)
      : file_(file), scene_(scene), config_(config) {}

  TriangleMesh run() {
    importMaterials();
    walk(*scene_.mRootNode, aiMatrix4x4(), -1);
    finish();
    return std::move(mesh_);
  }

 private:
  // ---- materials and textures --------------------------------------------
  void importMaterials() {
    materialIndex_.assign(scene_.mNumMaterials, -1);
    for (unsigned i = 0; i < scene_.mNumMaterials; ++i) {
      const aiMaterial& source = *scene_.mMaterials[i];
      aiString name;
      const bool named = source.Get(AI_MATKEY_NAME, name) == AI_SUCCESS;
      // assimp's stand-in for "no material" (OBJ) maps back to -1
      if (std::string_view(name.C_Str()) == AI_DEFAULT_MATERIAL_NAME) continue;
      Material material;
      material.name = name.C_Str();
      aiColor4D color(1.0f, 1.0f, 1.0f, 1.0f);
      if (source.Get(AI_MATKEY_BASE_COLOR, color) != AI_SUCCESS)
        source.Get(AI_MATKEY_COLOR_DIFFUSE, color);
      material.base_color = {color.r, color.g, color.b};
      aiString texturePath;
      if (source.GetTexture(aiTextureType_BASE_COLOR, 0, &texturePath) ==
              AI_SUCCESS ||
          source.GetTexture(aiTextureType_DIFFUSE, 0, &texturePath) ==
              AI_SUCCESS)
        material.texture = textureIndex(texturePath.C_Str(), material.name);
      // the glTF importer appends a nameless white default; it renders
      // exactly like "no material", so it becomes -1 as well
      if (!named && material == Material{}) continue;
      materialIndex_[i] = static_cast<int>(mesh_.materials.size());
      mesh_.materials.push_back(std::move(material));
    }
  }

  int textureIndex(const std::string& path, const std::string& materialName) {
    auto cached = textureByPath_.find(path);
    if (cached != textureByPath_.end()) return cached->second;

    cv::Mat bgr;
    std::string name;
    if (auto [embedded, index] =
            scene_.GetEmbeddedTextureAndIndex(path.c_str());
        embedded != nullptr) {
      name = embedded->mFilename.length > 0
                 ? std::string(embedded->mFilename.C_Str())
                 : strCat("texture_", index);
      if (embedded->mHeight == 0) {
        // compressed (PNG/JPEG) bytes, mWidth of them
        cv::Mat bytes(1, static_cast<int>(embedded->mWidth), CV_8UC1,
                      const_cast<aiTexel*>(embedded->pcData));
        bgr = cv::imdecode(bytes, cv::IMREAD_COLOR);
      } else {
        // raw BGRA texels
        cv::Mat bgra(static_cast<int>(embedded->mHeight),
                     static_cast<int>(embedded->mWidth), CV_8UC4,
                     const_cast<aiTexel*>(embedded->pcData));
        cv::cvtColor(bgra, bgr, cv::COLOR_BGRA2BGR);
      }
      VLN_CHECK_IO(!bgr.empty(), "loadScene(): ", file_,
                   ": cannot decode embedded texture '", path,
                   "' of material '", materialName, "'");
    } else {
      const fs::path image = file_.parent_path() / path;
      VLN_CHECK_IO(fs::exists(image), "loadScene(): ", file_, ": material '",
                   materialName, "' uses texture ", image,
                   " which does not exist");
      bgr = cv::imread(image.string(), cv::IMREAD_COLOR);
      VLN_CHECK_IO(!bgr.empty(), "loadScene(): ", file_,
                   ": cannot decode texture ", image, " of material '",
                   materialName, "'");
      name = image.stem().string();
      // undo the scene-stem prefix that saveScene() adds (see textureFileName)
      const std::string prefix = file_.stem().string() + "_";
      if (name.size() > prefix.size() && name.rfind(prefix, 0) == 0)
        name = name.substr(prefix.size());
    }
    const int index = static_cast<int>(mesh_.textures.size());
    mesh_.textures.push_back(textureFromBgr(bgr, std::move(name)));
    textureByPath_.emplace(path, index);
    return index;
  }

  // ---- geometry -----------------------------------------------------------
  Vec3f toWorld(const aiVector3D& p) const {
    // Habitat's Z-up convention: file (x, y, z) -> world (x, z, -y)
    const Vec3f world = config_.up_axis == UpAxis::kZ ? Vec3f(p.x, p.z, -p.y)
                                                      : Vec3f(p.x, p.y, p.z);
    return world * config_.scale;
  }

  void walk(const aiNode& node, const aiMatrix4x4& parent, int object) {
    const aiMatrix4x4 transform = parent * node.mTransformation;
    if (auto id = parseObjectName(node.mName.C_Str())) object = *id;
    for (unsigned i = 0; i < node.mNumMeshes; ++i)
      addMesh(*scene_.mMeshes[node.mMeshes[i]], transform, object);
    for (unsigned i = 0; i < node.mNumChildren; ++i)
      walk(*node.mChildren[i], transform, object);
  }

  // One imported vertex; assimp's OBJ reader emits one per face corner, so
  // exactly equal ones are joined here. (aiProcess_JoinIdenticalVertices of
  // assimp 5.2 merges vertices whose colours differ, so it is not used.)
  struct VertexKey {
    std::array<uint32_t, 5> bits;  // position x y z and uv u v as float bits
    Rgb8 color;
    bool operator==(const VertexKey&) const = default;
  };
  struct VertexKeyHash {
    size_t operator()(const VertexKey& key) const {
      uint64_t h = 0x9E3779B97F4A7C15ull;
      for (uint32_t b : key.bits) h = (h ^ b) * 0x100000001B3ull;
      for (uint8_t c : key.color) h = (h ^ c) * 0x100000001B3ull;
      return static_cast<size_t>(h ^ (h >> 29));
    }
  };

  static uint32_t floatBits(float value) {
    if (value == 0.0f) value = 0.0f;  // -0 and +0 are the same vertex
    uint32_t bits;
    std::memcpy(&bits, &value, sizeof(bits));
    return bits;
  }

  void addMesh(const aiMesh& source, const aiMatrix4x4& transform, int object) {
    if ((source.mPrimitiveTypes & aiPrimitiveType_TRIANGLE) == 0) return;
    if (object < 0)
      if (auto id = parseObjectName(source.mName.C_Str())) object = *id;
    const bool hasColors = source.HasVertexColors(0);
    const bool hasUvs = source.HasTextureCoords(0);
    const int material = source.mMaterialIndex < materialIndex_.size()
                             ? materialIndex_[source.mMaterialIndex]
                             : -1;

    // vertices are copied when a kept triangle first uses them, so points
    // and lines leave nothing behind
    std::vector<uint32_t> joined(source.mNumVertices, UINT32_MAX);
    std::unordered_map<VertexKey, uint32_t, VertexKeyHash> seen;
    auto vertex = [&](unsigned v) {
      if (joined[v] != UINT32_MAX) return joined[v];
      const Vec3f position = toWorld(transform * source.mVertices[v]);
      Rgb8 color{255, 255, 255};
      if (hasColors) {
        const aiColor4D& c = source.mColors[0][v];
        color = {unitToByte(c.r), unitToByte(c.g), unitToByte(c.b)};
      }
      const Vec2f uv = hasUvs ? Vec2f(source.mTextureCoords[0][v].x,
                                      source.mTextureCoords[0][v].y)
                              : Vec2f::Zero();
      const VertexKey key{
          {floatBits(position.x()), floatBits(position.y()),
           floatBits(position.z()), floatBits(uv.x()), floatBits(uv.y())},
          color};
      auto [it, inserted] =
          seen.emplace(key, static_cast<uint32_t>(mesh_.positions.size()));
      if (inserted) {
        mesh_.positions.push_back(position);
        colors_.push_back(color);
        uvs_.push_back(uv);
      }
      return joined[v] = it->second;
    };

    for (unsigned f = 0; f < source.mNumFaces; ++f) {
      const aiFace& face = source.mFaces[f];
      if (face.mNumIndices != 3) continue;  // stray points and lines
      for (int k = 0; k < 3; ++k)
        VLN_CHECK_ARG(face.mIndices[k] < source.mNumVertices,
                      "loadScene(): ", file_, ": mesh '", source.mName.C_Str(),
                      "' face ", f, " refers to vertex ", face.mIndices[k],
                      " of ", source.mNumVertices);
      // a corner repeated (by index or position) leaves no area
      const aiVector3D& a = source.mVertices[face.mIndices[0]];
      const aiVector3D& b = source.mVertices[face.mIndices[1]];
      const aiVector3D& c = source.mVertices[face.mIndices[2]];
      if (a == b || b == c || a == c) continue;
      for (int k = 0; k < 3; ++k)
        mesh_.indices.push_back(vertex(face.mIndices[k]));
      mesh_.triangle_material.push_back(material);
      mesh_.triangle_object.push_back(object);
      anyColors_ = anyColors_ || hasColors;
      anyUvs_ = anyUvs_ || hasUvs;
    }
  }

  // Optional arrays stay empty when the file had none of them; materials
  // and textures are reduced to those in use, in order of first use, for
  // every format alike (assimp's glTF reader already drops unused ones).
  void finish() {
    if (anyColors_) mesh_.colors = std::move(colors_);
    if (anyUvs_) mesh_.uvs = std::move(uvs_);
    keepUsedMaterials(mesh_);
    const auto isNone = [](int32_t value) { return value < 0; };
    if (std::all_of(mesh_.triangle_material.begin(),
                    mesh_.triangle_material.end(), isNone))
      mesh_.triangle_material.clear();
    if (std::all_of(mesh_.triangle_object.begin(), mesh_.triangle_object.end(),
                    isNone))
      mesh_.triangle_object.clear();
  }

  const fs::path& file_;
  const aiScene& scene_;
  const MeshLoadConfig& config_;
  TriangleMesh mesh_;
  std::vector<Rgb8> colors_;
  std::vector<Vec2f> uvs_;
  bool anyColors_ = false;
  bool anyUvs_ = false;
  std::vector<int> materialIndex_;
  std::unordered_map<std::string, int> textureByPath_;
};

// ===========================================================================
// semantics sidecar
// ===========================================================================

json vecJson(const Vec3f& v) { return {v.x(), v.y(), v.z()}; }

template <int N>
Eigen::Matrix<float, N, 1> readVec(const json& object, std::string_view key,
                                   const std::string& context) {
  const auto values =
      common::requireField<std::vector<float>>(object, key, context);
  VLN_CHECK_ARG(values.size() == N, context, ": field '", key, "' needs ", N,
                " numbers, got ", values.size());
  Eigen::Matrix<float, N, 1> v;
  for (int i = 0; i < N; ++i) {
    VLN_CHECK_ARG(std::isfinite(values[i]), context, ": field '", key,
                  "' has a non-finite value");
    v[i] = values[i];
  }
  return v;
}

// {"min": [..], "max": [..]} with min <= max
template <int N>
Eigen::AlignedBox<float, N> readBox(const json& object, std::string_view key,
                                    const std::string& context) {
  const auto box = common::requireField<json>(object, key, context);
  const std::string inner = strCat(context, ".", key);
  Eigen::AlignedBox<float, N> out(readVec<N>(box, "min", inner),
                                  readVec<N>(box, "max", inner));
  VLN_CHECK_ARG((out.min().array() <= out.max().array()).all(), inner,
                ": min exceeds max");
  return out;
}

template <class Box>
json boxJson(const Box& box) {
  json lo = json::array(), hi = json::array();
  for (int i = 0; i < box.dim(); ++i) {
    lo.push_back(box.min()[i]);
    hi.push_back(box.max()[i]);
  }
  return {{"min", lo}, {"max", hi}};
}

json requireArray(const json& root, std::string_view key,
                  const std::string& context) {
  const auto value = common::requireField<json>(root, key, context);
  VLN_CHECK_ARG(value.is_array(), context, ": field '", key,
                "' must be an array, got ", value.type_name());
  return value;
}

}  // namespace

// ===========================================================================
// public API
// ===========================================================================

fs::path semanticsPath(const fs::path& sceneFile) {
  return fs::path(sceneFile.string() + ".semantics.json");
}

SceneSemantics loadSemantics(const fs::path& file) {
  const json root = common::readJsonFile(file);
  const std::string source = file.string();
  SceneSemantics semantics;

  const json rooms = requireArray(root, "rooms", source);
  for (size_t i = 0; i < rooms.size(); ++i) {
    const std::string context = strCat(source, ": rooms[", i, "]");
    Room room;
    room.id = common::requireField<int>(rooms[i], "id", context);
    room.type = common::requireField<std::string>(rooms[i], "type", context);
    room.footprint = readBox<2>(rooms[i], "footprint", context);
    room.floor_y = common::requireField<float>(rooms[i], "floor_y", context);
    semantics.rooms.push_back(std::move(room));
  }

  const json doors = requireArray(root, "doors", source);
  for (size_t i = 0; i < doors.size(); ++i) {
    const std::string context = strCat(source, ": doors[", i, "]");
    Doorway door;
    door.room_a = common::requireField<int>(doors[i], "room_a", context);
    door.room_b = common::requireField<int>(doors[i], "room_b", context);
    door.center = readVec<3>(doors[i], "center", context);
    door.width = common::requireField<float>(doors[i], "width", context);
    VLN_CHECK_ARG(door.width > 0.0f, context,
                  ": field 'width' must be > 0, got ", door.width);
    door.normal = readVec<3>(doors[i], "normal", context);
    semantics.doors.push_back(door);
  }

  const json objects = requireArray(root, "objects", source);
  std::set<int> ids;
  for (size_t i = 0; i < objects.size(); ++i) {
    const std::string context = strCat(source, ": objects[", i, "]");
    SemanticObject object;
    object.id = common::requireField<int>(objects[i], "id", context);
    VLN_CHECK_ARG(object.id >= 0, context, ": field 'id' must be >= 0, got ",
                  object.id);
    VLN_CHECK_ARG(ids.insert(object.id).second, context,
                  ": field 'id' repeats id ", object.id);
    object.category =
        common::requireField<std::string>(objects[i], "category", context);
    object.color =
        common::requireField<std::string>(objects[i], "color", context);
    object.room = common::requireField<int>(objects[i], "room", context);
    object.bounds = readBox<3>(objects[i], "bounds", context);
    semantics.objects.push_back(std::move(object));
  }

  // room references must resolve
  std::set<int> roomIds;
  for (const Room& room : semantics.rooms) roomIds.insert(room.id);
  auto checkRoom = [&](int room, const std::string& context,
                       std::string_view field) {
    VLN_CHECK_ARG(room == -1 || roomIds.count(room) > 0, context, ": field '",
                  field, "' names room ", room, " which is not in 'rooms'");
  };
  for (size_t i = 0; i < semantics.doors.size(); ++i) {
    checkRoom(semantics.doors[i].room_a, strCat(source, ": doors[", i, "]"),
              "room_a");
    checkRoom(semantics.doors[i].room_b, strCat(source, ": doors[", i, "]"),
              "room_b");
  }
  for (size_t i = 0; i < semantics.objects.size(); ++i)
    checkRoom(semantics.objects[i].room, strCat(source, ": objects[", i, "]"),
              "room");
  return semantics;
}

void saveSemantics(const fs::path& file, const SceneSemantics& semantics) {
  json rooms = json::array();
  for (const Room& room : semantics.rooms)
    rooms.push_back({{"id", room.id},
                     {"type", room.type},
                     {"footprint", boxJson(room.footprint)},
                     {"floor_y", room.floor_y}});
  json doors = json::array();
  for (const Doorway& door : semantics.doors)
    doors.push_back({{"room_a", door.room_a},
                     {"room_b", door.room_b},
                     {"center", vecJson(door.center)},
                     {"width", door.width},
                     {"normal", vecJson(door.normal)}});
  json objects = json::array();
  for (const SemanticObject& object : semantics.objects)
    objects.push_back({{"id", object.id},
                       {"category", object.category},
                       {"color", object.color},
                       {"room", object.room},
                       {"bounds", boxJson(object.bounds)}});
  common::writeJsonFile(
      file, {{"rooms", rooms}, {"doors", doors}, {"objects", objects}},
      /*indent=*/1);
}

namespace {

// Debian's assimp 5.2 aborts in aiProcess_Triangulate (an ai_assert) on a
// mesh whose primitive types call for triangulation while no face has more
// than three corners, e.g. a PLY face list with a garbage count (found by
// fuzzing): such meshes are refused before post-processing.
// Its post-processing also reads vertices through face indices without
// checking them (a SEGV on a PLY face naming vertex 1503 of 8, found by
// fuzzing): every index must name a vertex of its mesh.
void checkFacesBeforePostProcessing(const aiScene& scene,
                                    const fs::path& file) {
  for (unsigned m = 0; m < scene.mNumMeshes; ++m) {
    VLN_CHECK_ARG(scene.mMeshes != nullptr && scene.mMeshes[m] != nullptr,
                  "loadScene(): ", file, " mesh ", m, " is missing");
    const aiMesh& mesh = *scene.mMeshes[m];
    VLN_CHECK_ARG((mesh.mNumFaces == 0 || mesh.mFaces != nullptr) &&
                      (mesh.mNumVertices == 0 || mesh.mVertices != nullptr),
                  "loadScene(): ", file, " mesh ", m,
                  " declares faces or vertices it does not hold");
    bool polygon = false, allTriangles = true;
    for (unsigned f = 0; f < mesh.mNumFaces; ++f) {
      const aiFace& face = mesh.mFaces[f];
      VLN_CHECK_ARG(face.mNumIndices == 0 || face.mIndices != nullptr,
                    "loadScene(): ", file, " mesh ", m, " face ", f,
                    " declares indices it does not hold");
      for (unsigned k = 0; k < face.mNumIndices; ++k)
        VLN_CHECK_ARG(face.mIndices[k] < mesh.mNumVertices,
                      "loadScene(): ", file, " mesh ", m, " face ", f,
                      " names vertex ", face.mIndices[k], " of ",
                      mesh.mNumVertices);
      polygon |= face.mNumIndices > 3;
      allTriangles &= face.mNumIndices == 3;
    }
    // the condition under which assimp's TriangulateProcess runs
    const bool triangulates =
        mesh.mPrimitiveTypes == 0
            ? !allTriangles
            : (mesh.mPrimitiveTypes & aiPrimitiveType_POLYGON) != 0;
    VLN_CHECK_ARG(!triangulates || polygon, "loadScene(): ", file, " mesh ", m,
                  " has faces that contradict its primitive types (a corrupt "
                  "face list)");
  }
}

}  // namespace

LoadedScene loadScene(const fs::path& file, const MeshLoadConfig& config) {
  VLN_CHECK_IO(fs::is_regular_file(file), "loadScene(): scene file ", file,
               " does not exist");
  checkPlyFile(file);
  Assimp::Importer importer;
  // Only triangulation and the uv flip are left to assimp: points, lines and
  // degenerate triangles are dropped while copying (assimp's own filters
  // would turn a file without faces into a read error instead of "no
  // triangles"). FlipUVs: our uvs put v = 0 on the first image row (glTF).
  // Post-processing runs separately, after checkFacesBeforePostProcessing().
  const aiScene* scene = importer.ReadFile(file.string(), 0);
  VLN_CHECK_IO(scene != nullptr, "loadScene(): assimp cannot read ", file, ": ",
               importer.GetErrorString());
  checkFacesBeforePostProcessing(*scene, file);
  scene =
      importer.ApplyPostProcessing(aiProcess_Triangulate | aiProcess_FlipUVs);
  VLN_CHECK_IO(scene != nullptr, "loadScene(): assimp cannot read ", file, ": ",
               importer.GetErrorString());
  VLN_CHECK_ARG(scene->mRootNode != nullptr && scene->mNumMeshes > 0,
                "loadScene(): ", file, " has no triangles (no meshes)");

  LoadedScene loaded;
  loaded.mesh = SceneImporter(file, *scene, config).run();
  VLN_CHECK_ARG(loaded.mesh.triangleCount() > 0, "loadScene(): ", file,
                " has no triangles");
  loaded.mesh.validate(strCat("loadScene(): ", file.string()));
  const fs::path sidecar = semanticsPath(file);
  if (fs::exists(sidecar)) loaded.semantics = loadSemantics(sidecar);
  return loaded;
}

void saveScene(const fs::path& file, const TriangleMesh& mesh,
               const SceneSemantics& semantics) {
  const std::string ext = lowerExtension(file);
  VLN_CHECK_ARG(ext == ".glb" || ext == ".obj", "saveScene(): ", file,
                ": unsupported extension '", ext, "' (use .glb or .obj)");
  mesh.validate(strCat("saveScene(): ", file.string()));
  if (ext == ".glb")
    writeGlb(file, mesh);
  else
    writeObj(file, mesh);
  // a sidecar left from an earlier scene of the same name would lie
  const fs::path sidecar = semanticsPath(file);
  if (!semantics.empty())
    saveSemantics(sidecar, semantics);
  else if (fs::exists(sidecar))
    fs::remove(sidecar);
}

}  // namespace vln::sim
