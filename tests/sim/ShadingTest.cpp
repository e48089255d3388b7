// Tests src/sim/Shading.cpp: HitShader's eight- and sixteen-lane paths
// (AVX2 + FMA and AVX-512F, where the CPU has them) against the portable
// rule hit by hit, bit for bit, and the portable rule against colours
// worked out by hand.

#include "sim/Shading.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <limits>
#include <random>
#include <vector>

#include "sim/Mesh.h"

namespace vln::sim {
namespace {

// Two textured materials (one 3x2, one 1x1), one plain, vertex colours and
// uvs far outside [0, 1) (wrapping), and a triangle with non-finite uvs.
TriangleMesh shadedMesh() {
  TriangleMesh mesh;
  Texture checker;
  checker.width = 3;
  checker.height = 2;
  checker.rgb = {255, 0,   0, 0, 255, 0,   0,  0,  255,
                 255, 255, 0, 0, 255, 255, 10, 20, 30};
  Texture single;
  single.width = 1;
  single.height = 1;
  single.rgb = {128, 64, 32};
  mesh.textures = {checker, single};
  Material textured;
  textured.base_color = {1.0f, 0.9f, 0.8f};
  textured.texture = 0;
  Material other = textured;
  other.texture = 1;
  Material plain;
  plain.base_color = {0.5f, 0.25f, 1.0f};
  mesh.materials = {textured, other, plain};
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> uv(-7.0f, 7.0f);
  std::uniform_int_distribution<int> channel(0, 255);
  for (int t = 0; t < 24; ++t) {
    const auto base = static_cast<uint32_t>(mesh.positions.size());
    for (int k = 0; k < 3; ++k) {
      mesh.positions.emplace_back(static_cast<float>(t), static_cast<float>(k),
                                  0.0f);
      mesh.uvs.emplace_back(uv(rng), uv(rng));
      mesh.colors.push_back(Rgb8{static_cast<uint8_t>(channel(rng)),
                                 static_cast<uint8_t>(channel(rng)),
                                 static_cast<uint8_t>(channel(rng))});
    }
    for (uint32_t k = 0; k < 3; ++k) mesh.indices.push_back(base + k);
    mesh.triangle_material.push_back(t % 4 == 3 ? -1 : t % 3);
  }
  mesh.uvs[3 * 5] = Vec2f(std::numeric_limits<float>::infinity(), 0.5f);
  return mesh;
}

// `rounds` random runs of kLanes hits through `shade` (a vector path of
// `vector`, or the same call on `portable`), compared lane by lane: runs of
// one, two or three triangles over the lanes (broadcast and blended
// records) and of up to kLanes (gathered); lanes outside the mask hold an
// invalid id and NaN (as Embree's misses) and must come out 0.
template <int kLanes, typename Shade>
void expectPortableBits(const HitShader& vector, const HitShader& portable,
                        Shade shade, uint32_t seed, int rounds) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<uint32_t> triangle(0, 23);
  std::uniform_real_distribution<float> weight(0.0f, 1.0f);
  std::uniform_int_distribution<unsigned> mask(0, (1u << kLanes) - 1u);
  for (int round = 0; round < rounds; ++round) {
    alignas(64) uint32_t triangles[kLanes];
    alignas(64) float u[kLanes];
    alignas(64) float v[kLanes];
    const uint32_t few[3] = {triangle(rng), triangle(rng), triangle(rng)};
    const int distinct = 1 + round % 4;
    for (int k = 0; k < kLanes; ++k) {
      triangles[k] =
          distinct <= 3 ? few[(k * 5 + round) % distinct] : triangle(rng);
      u[k] = weight(rng);
      v[k] = (1.0f - u[k]) * weight(rng);
    }
    const unsigned lanes = round % 3 == 0 ? (1u << kLanes) - 1u : mask(rng);
    for (int k = 0; k < kLanes; ++k)
      if (!((lanes >> k) & 1u)) {
        triangles[k] = 0xFFFFFFFFu;
        u[k] = std::numeric_limits<float>::quiet_NaN();
      }
    alignas(64) uint32_t a[kLanes];
    alignas(64) uint32_t b[kLanes];
    shade(vector, triangles, u, v, lanes, a);
    shade(portable, triangles, u, v, lanes, b);
    for (int k = 0; k < kLanes; ++k) {
      ASSERT_EQ(a[k], b[k]) << "round " << round << " lane " << k;
      if (!((lanes >> k) & 1u)) {
        EXPECT_EQ(a[k], 0u);
      }
    }
  }
}

TEST(HitShaderTest, EightLanePathShadesThePortableBits) {
  const TriangleMesh mesh = shadedMesh();
  const HitShader vector(mesh);
  const HitShader portable(mesh, /*vectorized=*/false);
  EXPECT_FALSE(portable.vectorized());
  if (!vector.vectorized())
    GTEST_LOG_(INFO)
        << "this CPU has no AVX2 + FMA: both run the portable path";
  expectPortableBits<8>(
      vector, portable,
      [](const HitShader& shader, const uint32_t* t, const float* u,
         const float* v, unsigned lanes,
         uint32_t* colors) { shader.shade8(t, u, v, lanes, colors); },
      9, 2000);
}

TEST(HitShaderTest, SixteenLanePathShadesThePortableBits) {
  // Embree's packets: AVX-512F where the CPU has it, else two halves
  const TriangleMesh mesh = shadedMesh();
  const HitShader vector(mesh);
  const HitShader portable(mesh, /*vectorized=*/false);
  expectPortableBits<16>(
      vector, portable,
      [](const HitShader& shader, const uint32_t* t, const float* u,
         const float* v, unsigned lanes,
         uint32_t* colors) { shader.shade16(t, u, v, lanes, colors); },
      13, 1000);
}

TEST(HitShaderTest, PortableRuleIsBaseTimesVertexColourTimesTexture) {
  TriangleMesh mesh;
  mesh.positions = {Vec3f(0, 0, 0), Vec3f(1, 0, 0), Vec3f(0, 1, 0)};
  mesh.indices = {0, 1, 2};
  mesh.colors = {Rgb8{255, 255, 255}, Rgb8{0, 255, 255}, Rgb8{255, 0, 255}};
  // uv (0.25, 0.25) everywhere: the centre of texel (0, 0) of a 2x2 texture
  mesh.uvs = {Vec2f(0.25f, 0.25f), Vec2f(0.25f, 0.25f), Vec2f(0.25f, 0.25f)};
  Texture texture;
  texture.width = 2;
  texture.height = 2;
  texture.rgb = {200, 100, 50, 0, 0, 0, 0, 0, 0, 0, 0, 0};
  mesh.textures = {texture};
  Material material;
  material.base_color = {1.0f, 0.5f, 1.0f};
  material.texture = 0;
  mesh.materials = {material};
  mesh.triangle_material = {0};
  const HitShader shader(mesh, /*vectorized=*/false);
  alignas(32) const uint32_t triangles[8] = {};
  // corner 0 (white), then halfway to corner 1 (no red)
  alignas(32) const float u[8] = {0.0f, 0.5f};
  alignas(32) const float v[8] = {0.0f, 0.0f};
  alignas(32) uint32_t colors[8];
  shader.shade8(triangles, u, v, 0x3u, colors);
  // red 200, green 100 x 0.5 = 50, blue 50
  EXPECT_EQ(colors[0], 200u | 50u << 8 | 50u << 16);
  // red 200 x 0.5 = 100
  EXPECT_EQ(colors[1], 100u | 50u << 8 | 50u << 16);
}

}  // namespace
}  // namespace vln::sim
