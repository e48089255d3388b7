#include "sim/SceneFileLayout.h"

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <charconv>

#include "common/Check.h"

namespace vln::sim {

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

std::string groupName(int object) {
  return object < 0 ? std::string(kStructureNode)
                    : strCat(kObjectPrefix, object);
}

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

void keepUsedMaterials(TriangleMesh& mesh, const std::vector<uint32_t>* order) {
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

}  // namespace vln::sim
