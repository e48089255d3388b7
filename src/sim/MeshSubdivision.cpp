#include "sim/MeshSubdivision.h"

#include <cmath>
#include <cstdint>
#include <vector>

#include "common/Check.h"

namespace vln::sim {

TriangleMesh subdivide(const TriangleMesh& mesh, int n) {
  VLN_CHECK_ARG(n >= 1, "subdivide(): n must be >= 1, got ", n);
  TriangleMesh out;
  out.materials = mesh.materials;
  out.textures = mesh.textures;
  const bool colors = !mesh.colors.empty();
  const bool uvs = !mesh.uvs.empty();
  const float step = 1.0f / static_cast<float>(n);
  std::vector<uint32_t> grid;
  for (size_t t = 0; t < mesh.triangleCount(); ++t) {
    const uint32_t c[3] = {mesh.indices[3 * t], mesh.indices[3 * t + 1],
                           mesh.indices[3 * t + 2]};
    // vertices at barycentric (i/n, j/n) towards corners 1 and 2, i + j <= n
    grid.clear();
    for (int i = 0; i <= n; ++i) {
      for (int j = 0; i + j <= n; ++j) {
        const float b1 = static_cast<float>(i) * step;
        const float b2 = static_cast<float>(j) * step;
        const float b0 = 1.0f - b1 - b2;
        out.positions.push_back(b0 * mesh.positions[c[0]] +
                                b1 * mesh.positions[c[1]] +
                                b2 * mesh.positions[c[2]]);
        if (colors) {
          Rgb8 color;
          for (int k = 0; k < 3; ++k)
            color[k] = static_cast<uint8_t>(std::lround(
                b0 * mesh.colors[c[0]][k] + b1 * mesh.colors[c[1]][k] +
                b2 * mesh.colors[c[2]][k]));
          out.colors.push_back(color);
        }
        if (uvs)
          out.uvs.push_back(b0 * mesh.uvs[c[0]] + b1 * mesh.uvs[c[1]] +
                            b2 * mesh.uvs[c[2]]);
        grid.push_back(static_cast<uint32_t>(out.positions.size() - 1));
      }
    }
    // row i holds n + 1 - i vertices
    auto at = [&](int i, int j) {
      return grid[static_cast<size_t>(i * (n + 1) - i * (i - 1) / 2 + j)];
    };
    for (int i = 0; i < n; ++i) {
      for (int j = 0; i + j < n; ++j) {
        for (uint32_t index : {at(i, j), at(i + 1, j), at(i, j + 1)})
          out.indices.push_back(index);
        if (i + j + 1 < n)
          for (uint32_t index : {at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)})
            out.indices.push_back(index);
      }
    }
    const size_t pieces = static_cast<size_t>(n) * static_cast<size_t>(n);
    if (!mesh.triangle_material.empty())
      out.triangle_material.insert(out.triangle_material.end(), pieces,
                                   mesh.triangle_material[t]);
    if (!mesh.triangle_object.empty())
      out.triangle_object.insert(out.triangle_object.end(), pieces,
                                 mesh.triangle_object[t]);
  }
  return out;
}

}  // namespace vln::sim
