#pragma once
// Private to the sim module: the unlit material rule of Renderer.h (colour =
// base colour x vertex colour x texture) as the ray-casting and rasterising
// backends that share it evaluate it per hit. Use createRenderer()
// (Renderer.h) instead of including this.

#include <cstdint>
#include <optional>
#include <vector>

namespace vln::sim {

struct TriangleMesh;

// The portable paths (the shading here, Embree's ray set-up) compute exactly
// what their vector twins compute, operation for operation: each
// multiply-add a vector path fuses is a std::fma there (one rounding), in
// the same order, and the clamps keep its NaN rules. So the vector units of a
// CPU never change an image, and runs on any machine train the same weights
// (docs/reliability.md, "Across machines"). Built twice (target_clones): with
// FMA instructions for every AVX2 CPU, and for the baseline, where std::fma is
// libm's correctly rounded fmaf, slower and equal.
#define VLN_PORTABLE_FMA __attribute__((target_clones("fma", "default")))

// Everything shading needs about one triangle, in one cache line and laid
// out for 4-wide SSE loads: colour (base colour x vertex colour, in [0, 1])
// at corner 0 and its changes towards corners 1 and 2, so a hit's colour is
// c0 + u dc1 + v dc2 with Embree's barycentrics (p = (1-u-v) p0 + u p1 +
// v p2); the same for uv. The fourth lane of each colour row carries a
// scalar so the record stays 64 bytes.
struct alignas(64) TriangleShade {
  float color0[3];
  int32_t texture;  // index into TriangleMesh::textures or -1
  float dcolor1[3];
  float s0;  // uv at corner 0
  float dcolor2[3];
  float t0;
  float duv[4];  // d(s, t) towards corner 1, then towards corner 2
};
static_assert(sizeof(TriangleShade) == 64);

// A texture as the sampler needs it.
struct TextureView {
  const uint8_t* rgb = nullptr;
  int width = 0;
  int height = 0;
};

// All textures in one RGB8 buffer (plus 4 bytes of padding so a 4-byte
// gather of the last texel stays inside it), addressed by byte offset, as
// the vector paths gather them.
struct PackedTextures {
  std::vector<uint8_t> texels;
  std::vector<int32_t> offset;
  std::vector<int32_t> width;
  std::vector<int32_t> height;
};

/// The material rule of one scene, ready to shade hits: the shading table,
/// the textures and, for the vector paths, their packed copy. A hit's colour
/// (r | g << 8 | b << 16) is base colour x vertex colour x texture,
/// interpolated with its barycentrics; the texture is sampled bilinearly
/// with wrap, as GL_LINEAR + GL_REPEAT without mipmaps (texel centres at
/// (i + 0.5) / size, row 0 at v = 0, the rows uploaded in the same order by
/// the OSMesa rasteriser). One portable path computes it hit by hit; AVX2 +
/// FMA (eight hits) and AVX-512F (sixteen) twins, where the CPU has them,
/// run the same operations in the same order, so the bits do not depend on
/// the CPU (tests compare them).
class HitShader {
 public:
  /// `vectorized` false keeps to the portable path (for tests); so do CPUs
  /// without AVX2 and FMA, and textures beyond the gathers' 32-bit offsets.
  explicit HitShader(const TriangleMesh& mesh, bool vectorized = true);

  /// Colours of the hits in the lanes set in `mask`
  /// (bit k = lane k, k < 8): triangle ids and Embree's barycentrics u, v
  /// of each lane, eight readable entries each; lanes outside `mask` get 0
  /// whatever their entries hold.
  void shade8(const uint32_t* triangles, const float* u, const float* v,
              unsigned mask, uint32_t colors[8]) const;

  /// shade8() for sixteen lanes (Embree's packets), sixteen readable
  /// entries each: at once with AVX-512F where the CPU has it (the same bits
  /// again), else as two halves.
  void shade16(const uint32_t* triangles, const float* u, const float* v,
               unsigned mask, uint32_t colors[16]) const;

  /// Whether shade8() runs the AVX2 path.
  bool vectorized() const { return avx2_; }

 private:
  std::vector<TriangleShade> table_;
  std::vector<TextureView> textures_;
  std::optional<PackedTextures> packed_;
  bool avx2_ = false;
  bool avx512_ = false;
};

/// Whether this CPU has AVX-512F (the vector paths that need it are chosen
/// at run time).
bool cpuHasAvx512();

/// Writes a colour as HitShader gives it (r | g << 8 | b << 16) to the
/// three bytes of an RGB pixel.
inline void writeColor(uint32_t color, uint8_t* rgb) {
  rgb[0] = static_cast<uint8_t>(color);
  rgb[1] = static_cast<uint8_t>(color >> 8);
  rgb[2] = static_cast<uint8_t>(color >> 16);
}

}  // namespace vln::sim
