#include "sim/MeshImport.h"

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
#include <cmath>
#include <cstring>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "common/Check.h"
#include "common/Config.h"
#include "sim/GeometryCheck.h"
#include "sim/PlyCheck.h"
#include "sim/SceneFileLayout.h"

namespace vln::sim {
namespace fs = std::filesystem;

namespace {

uint8_t unitToByte(float value) {
  // rounding (not truncation) makes byte -> float -> byte exact
  const float clamped = std::clamp(value, 0.0f, 1.0f);
  return static_cast<uint8_t>(std::lround(clamped * 255.0f));
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
      // undo the scene-stem prefix that the .obj writer adds (ObjWriter.cpp)
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

// The triangle limit, checked on assimp's faces before they are copied.
void checkFaceCount(const aiScene& scene, const fs::path& file) {
  size_t faces = 0;
  for (unsigned m = 0; m < scene.mNumMeshes; ++m)
    faces += scene.mMeshes[m]->mNumFaces;
  VLN_CHECK_ARG(faces <= kMaxSceneTriangles, "loadScene(): ", file, " has ",
                faces, " faces, more than the limit of ", kMaxSceneTriangles,
                " triangles (sim::kMaxSceneTriangles)");
}

}  // namespace

TriangleMesh importMesh(const fs::path& file, const MeshLoadConfig& config) {
  // values set in code bypass the YAML reader's bounds (a scale of 0 or NaN
  // would make every triangle degenerate or every vertex NaN)
  MeshLoadConfig checked = config;
  common::checkConfig([&](common::ConfigVisitor& v) { checked.visit(v); },
                      strCat("loadScene(): ", file.string(), ": mesh config"));
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

  checkFaceCount(*scene, file);

  TriangleMesh mesh = SceneImporter(file, *scene, config).run();
  VLN_CHECK_ARG(mesh.triangleCount() > 0, "loadScene(): ", file,
                " has no triangles");
  const std::string source = strCat("loadScene(): ", file.string());
  mesh.validate(source);
  checkSceneGeometry(mesh, source);
  return mesh;
}

}  // namespace vln::sim
