#include "sim/ObjWriter.h"

#include <assimp/material.h>

#include <cctype>
#include <charconv>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include "common/Check.h"
#include "common/FileIo.h"
#include "sim/SceneFileLayout.h"

namespace vln::sim {
namespace fs = std::filesystem;

namespace {

// shortest text that parses back to the same float
std::string floatText(float value) {
  char buffer[32];
  auto [end, ec] = std::to_chars(buffer, buffer + sizeof(buffer), value);
  VLN_ASSERT(ec == std::errc());
  return std::string(buffer, end);
}

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

}  // namespace

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

}  // namespace vln::sim
