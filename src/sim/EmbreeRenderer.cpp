#include "sim/EmbreeRenderer.h"

#include <embree3/rtcore.h>
#include <immintrin.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <optional>
#include <string_view>
#include <vector>

#include "common/Check.h"
#include "sim/Mesh.h"
#include "sim/RayTracer.h"

namespace vln::sim {

namespace {

// Which images one pass writes (a bit set of Renderer::Output).
using enum Renderer::Output;

// Packets are 4x4 pixel tiles: 16 rays that leave the same eye through
// neighbouring pixels traverse nearly the same BVH nodes.
constexpr int kTile = 4;
constexpr int kPacket = kTile * kTile;

// Denormal floats are 100x slower on x86 and appear in Embree's traversal
// for rays almost parallel to a box face. Flush them to zero for the duration
// of a render and restore the caller's MXCSR afterwards, so the setting never
// leaks into the caller's own arithmetic.
class FlushDenormalsScope {
 public:
  FlushDenormalsScope() : saved_(_mm_getcsr()) {
    _MM_SET_FLUSH_ZERO_MODE(_MM_FLUSH_ZERO_ON);
    _MM_SET_DENORMALS_ZERO_MODE(_MM_DENORMALS_ZERO_ON);
  }
  ~FlushDenormalsScope() { _mm_setcsr(saved_); }
  FlushDenormalsScope(const FlushDenormalsScope&) = delete;
  FlushDenormalsScope& operator=(const FlushDenormalsScope&) = delete;

 private:
  unsigned saved_;
};

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

// floor() for |x| < 2^31 without SSE4.1's roundss: the baseline x86-64 build
// would otherwise call into libm for every texel coordinate
inline int floorToInt(float x) {
  const int i = static_cast<int>(x);
  return i - (x < static_cast<float>(i) ? 1 : 0);
}

// The shading table of `mesh` (see TriangleShade).
std::vector<TriangleShade> buildShadeTable(const TriangleMesh& mesh) {
  std::vector<TriangleShade> table(mesh.triangleCount());
  for (size_t t = 0; t < table.size(); ++t) {
    const uint32_t* corner = mesh.indices.data() + 3 * t;
    std::array<float, 3> base{1.0f, 1.0f, 1.0f};
    int texture = -1;
    const int material = mesh.triangle_material.empty() ? -1 : mesh.triangle_material[t];
    if (material >= 0) {
      base = mesh.materials[static_cast<size_t>(material)].base_color;
      texture = mesh.materials[static_cast<size_t>(material)].texture;
    }
    float color[3][3];
    for (int k = 0; k < 3; ++k) {
      for (int c = 0; c < 3; ++c) {
        const float vertex = mesh.colors.empty()
                                 ? 1.0f
                                 : mesh.colors[corner[k]][c] * (1.0f / 255.0f);
        color[k][c] = base[c] * vertex;
      }
    }
    TriangleShade& shade = table[t];
    for (int c = 0; c < 3; ++c) {
      shade.color0[c] = color[0][c];
      shade.dcolor1[c] = color[1][c] - color[0][c];
      shade.dcolor2[c] = color[2][c] - color[0][c];
    }
    shade.texture = texture;
    Vec2f uv[3] = {Vec2f::Zero(), Vec2f::Zero(), Vec2f::Zero()};
    if (!mesh.uvs.empty())
      for (int k = 0; k < 3; ++k) uv[k] = mesh.uvs[corner[k]];
    shade.s0 = uv[0].x();
    shade.t0 = uv[0].y();
    shade.duv[0] = uv[1].x() - uv[0].x();
    shade.duv[1] = uv[1].y() - uv[0].y();
    shade.duv[2] = uv[2].x() - uv[0].x();
    shade.duv[3] = uv[2].y() - uv[0].y();
  }
  return table;
}

// The portable path computes exactly what the AVX-512 path below computes,
// operation for operation: each multiply-add that path fuses is a
// std::fma here (one rounding), in the same order, and the clamps keep its
// NaN rules. So a CPU without AVX-512 renders the same bits as one with it,
// and runs on either machine train the same weights (docs/reliability.md,
// "Across machines"). Built twice (target_clones): with FMA instructions for
// every AVX2 CPU, and for the baseline, where std::fma is libm's correctly
// rounded fmaf, slower and equal.
#define VLN_PORTABLE_FMA __attribute__((target_clones("fma", "default")))

// GL's float-to-unorm conversion as the packet path does it: max(c, 0) and
// min(c, 1) with SSE's rules (a NaN becomes 0), scale, round to nearest.
inline uint32_t unormByte(float c) {
  c = c > 0.0f ? c : 0.0f;
  c = c < 1.0f ? c : 1.0f;
  return static_cast<uint32_t>(static_cast<int32_t>(std::fma(c, 255.0f, 0.5f)));
}

// Colour of one hit as r | g << 8 | b << 16: base colour x vertex colour x
// texture, interpolated with the hit's barycentrics; the texture is sampled
// bilinearly with wrap, as GL_LINEAR + GL_REPEAT without mipmaps (texel
// centres at (i + 0.5) / size, row 0 at v = 0, the rows uploaded in the same
// order by the rasteriser).
VLN_PORTABLE_FMA uint32_t
shadePortable(const TriangleShade& t, float u, float v,
              const std::vector<TextureView>& textures) {
  float color[3];
  for (int c = 0; c < 3; ++c)
    color[c] =
        std::fma(v, t.dcolor2[c], std::fma(u, t.dcolor1[c], t.color0[c]));
  if (t.texture >= 0) {
    const TextureView& texture = textures[static_cast<size_t>(t.texture)];
    float s = std::fma(v, t.duv[2], std::fma(u, t.duv[0], t.s0));
    float r = std::fma(v, t.duv[3], std::fma(u, t.duv[1], t.t0));
    // non-finite or absurd coordinates sample texel row/column 0; then
    // wrapped into [0, 1), the lower texel is in [-1, size - 1] and the
    // upper in [0, size]: one comparison each wraps them
    if (!(std::abs(s) < 1e6f)) s = 0.0f;
    if (!(std::abs(r) < 1e6f)) r = 0.0f;
    s -= static_cast<float>(floorToInt(s));
    r -= static_cast<float>(floorToInt(r));
    const int width = texture.width;
    const int height = texture.height;
    const float x = std::fma(s, static_cast<float>(width), -0.5f);
    const float y = std::fma(r, static_cast<float>(height), -0.5f);
    int x0 = floorToInt(x);
    int y0 = floorToInt(y);
    const float fx = x - static_cast<float>(x0);
    const float fy = y - static_cast<float>(y0);
    int x1 = x0 + 1;
    int y1 = y0 + 1;
    if (x0 < 0) x0 += width;
    if (y0 < 0) y0 += height;
    if (x1 >= width) x1 -= width;
    if (y1 >= height) y1 -= height;
    const ptrdiff_t stride = static_cast<ptrdiff_t>(width) * 3;
    const uint8_t* t00 = texture.rgb + y0 * stride + 3 * x0;
    const uint8_t* t10 = texture.rgb + y0 * stride + 3 * x1;
    const uint8_t* t01 = texture.rgb + y1 * stride + 3 * x0;
    const uint8_t* t11 = texture.rgb + y1 * stride + 3 * x1;
    constexpr float kInv255 = 1.0f / 255.0f;
    const float gx = 1.0f - fx;
    const float gy = 1.0f - fy;
    const float w00 = gx * gy * kInv255;
    const float w10 = fx * gy * kInv255;
    const float w01 = gx * fy * kInv255;
    const float w11 = fx * fy * kInv255;
    for (int c = 0; c < 3; ++c) {
      const float sample =
          std::fma(w11, static_cast<float>(t11[c]),
                   std::fma(w01, static_cast<float>(t01[c]),
                            std::fma(w10, static_cast<float>(t10[c]),
                                     w00 * static_cast<float>(t00[c]))));
      color[c] = color[c] * sample;
    }
  }
  return unormByte(color[0]) | unormByte(color[1]) << 8 |
         unormByte(color[2]) << 16;
}

// Directions of the 16 primary rays of a 4x4 tile, reset tfar and hit, and
// the valid mask, as setupPacketAvx512() computes them (direction = x *
// right + (y * up - back), two roundings).
VLN_PORTABLE_FMA void setupPacketPortable(
    const float* columnX, const float* rowY, const Eigen::Matrix3f& toWorld,
    int columns, int rows, RTCRayHit16& packet, int valid[kPacket]) {
  float* directions[3] = {packet.ray.dir_x, packet.ray.dir_y, packet.ray.dir_z};
  for (int k = 0; k < kPacket; ++k) {
    const int column = k & (kTile - 1);
    const int row = k / kTile;
    valid[k] = (column < columns && row < rows) ? -1 : 0;
    const float x = columnX[column];
    const float y = rowY[row];
    for (int axis = 0; axis < 3; ++axis)
      directions[axis][k] =
          std::fma(x, toWorld(axis, 0),
                   std::fma(y, toWorld(axis, 1), -toWorld(axis, 2)));
    packet.ray.tfar[k] = std::numeric_limits<float>::infinity();
    packet.hit.geomID[k] = RTC_INVALID_GEOMETRY_ID;
  }
}

// ---------------------------------------------------------------------------
// AVX-512 shading of a whole packet
// ---------------------------------------------------------------------------

// All textures in one RGB8 buffer (plus 4 bytes of padding so a 4-byte
// gather of the last texel stays inside it), addressed by byte offset.
struct PackedTextures {
  std::vector<uint8_t> texels;
  std::vector<int32_t> offset;
  std::vector<int32_t> width;
  std::vector<int32_t> height;
};

// The packed copy of the mesh's textures, or nullopt when they exceed the
// 32-bit offsets of the gathers.
std::optional<PackedTextures> packTextures(const TriangleMesh& mesh) {
  PackedTextures packed;
  size_t total = 0;
  for (const Texture& texture : mesh.textures) total += texture.rgb.size();
  if (total + 4 > static_cast<size_t>(std::numeric_limits<int32_t>::max()))
    return std::nullopt;
  packed.texels.reserve(total + 4);
  for (const Texture& texture : mesh.textures) {
    packed.offset.push_back(static_cast<int32_t>(packed.texels.size()));
    packed.width.push_back(texture.width);
    packed.height.push_back(texture.height);
    packed.texels.insert(packed.texels.end(), texture.rgb.begin(), texture.rgb.end());
  }
  packed.texels.resize(packed.texels.size() + 4, 0);
  // gathers index these by texture id; keep them non-empty
  if (packed.offset.empty()) {
    packed.offset.push_back(0);
    packed.width.push_back(1);
    packed.height.push_back(1);
  }
  return packed;
}

bool cpuHasAvx512() {
  __builtin_cpu_init();
  return __builtin_cpu_supports("avx512f") != 0;
}

// Everything up to the matching pop_options is compiled for AVX-512F + FMA
// (lambdas included, which a function attribute would not cover) and only
// called after cpuHasAvx512().
#if defined(__clang__)
#pragma clang attribute push(__attribute__((target("avx512f,fma"))), \
                             apply_to = function)
#else
#pragma GCC push_options
#pragma GCC target("avx512f,fma")
#endif

// GCC 12's unmasked forms of several intrinsics start from an "undefined"
// register and trip -Wuninitialized; the all-lanes zero-masked forms are the
// same instructions without the warning.
constexpr __mmask16 kAll = 0xFFFF;

// shadePortable() for the 16 lanes of a packet at once (the portable path
// takes ~100 instructions per textured pixel; this ~15). Lanes outside
// `hitMask` get 0. Every operation here has its twin there: change both.
void shadePacketAvx512(const TriangleShade* table,
                                  const PackedTextures& textures,
                                  const RTCHit16& hits, unsigned hitMask,
                                  uint32_t packed[kPacket]) {
  const __mmask16 lanes = static_cast<__mmask16>(hitMask);
  const __m512i zero = _mm512_setzero_si512();
  const __m512 zerof = _mm512_setzero_ps();
  // fields of each lane's TriangleShade record (16 floats per record). In
  // most packets every lane hits the same large triangle (walls, floors);
  // broadcasting its record then replaces 16 gathers, the dominant cost.
  const __m512i primitive = _mm512_maskz_loadu_epi32(lanes, hits.primID);
  const unsigned firstLane = static_cast<unsigned>(__builtin_ctz(hitMask | 0x10000u));
  const uint32_t firstPrimitive = firstLane < kPacket ? hits.primID[firstLane] : 0u;
  const bool uniform =
      _mm512_mask_cmpneq_epi32_mask(lanes, primitive,
                                    _mm512_set1_epi32(static_cast<int>(firstPrimitive))) == 0;
  const __m512i record = _mm512_maskz_slli_epi32(kAll, primitive, 4);
  const auto* base = reinterpret_cast<const float*>(table);
  const float* uniformRecord = base + 16 * static_cast<size_t>(firstPrimitive);
  auto field = [&](int index) {
    if (uniform) return _mm512_set1_ps(uniformRecord[index]);
    return _mm512_mask_i32gather_ps(zerof, lanes,
                                    _mm512_add_epi32(record, _mm512_set1_epi32(index)),
                                    base, 4);
  };
  const __m512 u = _mm512_maskz_loadu_ps(lanes, hits.u);
  const __m512 v = _mm512_maskz_loadu_ps(lanes, hits.v);
  __m512 r = _mm512_fmadd_ps(v, field(8), _mm512_fmadd_ps(u, field(4), field(0)));
  __m512 g = _mm512_fmadd_ps(v, field(9), _mm512_fmadd_ps(u, field(5), field(1)));
  __m512 b = _mm512_fmadd_ps(v, field(10), _mm512_fmadd_ps(u, field(6), field(2)));
  const __m512i texture = _mm512_castps_si512(field(3));
  const __mmask16 textured = _mm512_mask_cmpge_epi32_mask(lanes, texture, zero);

  if (textured != 0) {
    // uv, sanitised and wrapped into [0, 1) as in sampleBilinear()
    __m512 s = _mm512_fmadd_ps(v, field(14), _mm512_fmadd_ps(u, field(12), field(7)));
    __m512 t = _mm512_fmadd_ps(v, field(15), _mm512_fmadd_ps(u, field(13), field(11)));
    const __m512 limit = _mm512_set1_ps(1e6f);
    s = _mm512_maskz_mov_ps(_mm512_cmp_ps_mask(_mm512_abs_ps(s), limit, _CMP_LT_OQ), s);
    t = _mm512_maskz_mov_ps(_mm512_cmp_ps_mask(_mm512_abs_ps(t), limit, _CMP_LT_OQ), t);
    constexpr int kFloor = _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC;
    s = _mm512_sub_ps(s, _mm512_maskz_roundscale_ps(kAll, s, kFloor));
    t = _mm512_sub_ps(t, _mm512_maskz_roundscale_ps(kAll, t, kFloor));
    // per-texture size and offset, broadcast when all lanes share a triangle
    auto textureField = [&](const std::vector<int32_t>& values) {
      if (uniform) return _mm512_set1_epi32(values[static_cast<size_t>(table[firstPrimitive].texture)]);
      return _mm512_mask_i32gather_epi32(zero, textured, texture, values.data(), 4);
    };
    const __m512i width = textureField(textures.width);
    const __m512i height = textureField(textures.height);
    const __m512i offset = textureField(textures.offset);
    const __m512 half = _mm512_set1_ps(0.5f);
    const __m512 x = _mm512_fmsub_ps(s, _mm512_maskz_cvtepi32_ps(kAll, width), half);
    const __m512 y = _mm512_fmsub_ps(t, _mm512_maskz_cvtepi32_ps(kAll, height), half);
    const __m512 x0f = _mm512_maskz_roundscale_ps(kAll, x, kFloor);
    const __m512 y0f = _mm512_maskz_roundscale_ps(kAll, y, kFloor);
    const __m512 fx = _mm512_sub_ps(x, x0f);
    const __m512 fy = _mm512_sub_ps(y, y0f);
    // texel indices wrapped with one comparison each
    __m512i x0 = _mm512_maskz_cvttps_epi32(kAll, x0f);
    __m512i y0 = _mm512_maskz_cvttps_epi32(kAll, y0f);
    const __m512i one = _mm512_set1_epi32(1);
    __m512i x1 = _mm512_add_epi32(x0, one);
    __m512i y1 = _mm512_add_epi32(y0, one);
    x0 = _mm512_mask_add_epi32(x0, _mm512_cmplt_epi32_mask(x0, zero), x0, width);
    y0 = _mm512_mask_add_epi32(y0, _mm512_cmplt_epi32_mask(y0, zero), y0, height);
    x1 = _mm512_mask_sub_epi32(x1, _mm512_cmpge_epi32_mask(x1, width), x1, width);
    y1 = _mm512_mask_sub_epi32(y1, _mm512_cmpge_epi32_mask(y1, height), y1, height);
    // byte addresses of the four texels
    const __m512i three = _mm512_set1_epi32(3);
    const __m512i row0 = _mm512_mullo_epi32(y0, width);
    const __m512i row1 = _mm512_mullo_epi32(y1, width);
    auto address = [&](__m512i row, __m512i column) {
      return _mm512_add_epi32(offset, _mm512_mullo_epi32(_mm512_add_epi32(row, column), three));
    };
    const auto* texels = reinterpret_cast<const int*>(textures.texels.data());
    auto fetch = [&](__m512i at) {
      return _mm512_mask_i32gather_epi32(zero, textured, at, texels, 1);
    };
    const __m512i t00 = fetch(address(row0, x0));
    const __m512i t10 = fetch(address(row0, x1));
    const __m512i t01 = fetch(address(row1, x0));
    const __m512i t11 = fetch(address(row1, x1));
    const __m512 inv255 = _mm512_set1_ps(1.0f / 255.0f);
    const __m512 onef = _mm512_set1_ps(1.0f);
    const __m512 gx = _mm512_sub_ps(onef, fx);
    const __m512 gy = _mm512_sub_ps(onef, fy);
    const __m512 w00 = _mm512_mul_ps(_mm512_mul_ps(gx, gy), inv255);
    const __m512 w10 = _mm512_mul_ps(_mm512_mul_ps(fx, gy), inv255);
    const __m512 w01 = _mm512_mul_ps(_mm512_mul_ps(gx, fy), inv255);
    const __m512 w11 = _mm512_mul_ps(_mm512_mul_ps(fx, fy), inv255);
    const __m512i byteMask = _mm512_set1_epi32(0xFF);
    auto channel = [&](int shift) {
      auto value = [&](__m512i texel) {
        return _mm512_maskz_cvtepi32_ps(kAll, 
            _mm512_and_si512(_mm512_maskz_srli_epi32(kAll, texel, static_cast<unsigned>(shift)), byteMask));
      };
      return _mm512_fmadd_ps(
          w11, value(t11),
          _mm512_fmadd_ps(w01, value(t01),
                          _mm512_fmadd_ps(w10, value(t10), _mm512_mul_ps(w00, value(t00)))));
    };
    r = _mm512_mask_mul_ps(r, textured, r, channel(0));
    g = _mm512_mask_mul_ps(g, textured, g, channel(8));
    b = _mm512_mask_mul_ps(b, textured, b, channel(16));
  }

  // GL's float-to-unorm conversion, then r | g << 8 | b << 16
  const __m512 scale = _mm512_set1_ps(255.0f);
  const __m512 half = _mm512_set1_ps(0.5f);
  const __m512 onef = _mm512_set1_ps(1.0f);
  auto toByte = [&](__m512 c) {
    c = _mm512_maskz_min_ps(kAll, _mm512_maskz_max_ps(kAll, c, zerof), onef);
    return _mm512_maskz_cvttps_epi32(kAll, _mm512_fmadd_ps(c, scale, half));
  };
  const __m512i rgb = _mm512_or_si512(
      toByte(r), _mm512_or_si512(_mm512_maskz_slli_epi32(kAll, toByte(g), 8),
                                 _mm512_maskz_slli_epi32(kAll, toByte(b), 16)));
  _mm512_storeu_si512(packed, _mm512_maskz_mov_epi32(lanes, rgb));
}

// Directions of the 16 primary rays of a 4x4 tile (lane k is column k % 4,
// row k / 4), reset tfar and hit, and the valid mask for tiles overhanging
// the image; the same bits as setupPacketPortable(). `columnX` and `rowY`
// point at the tile's first column and row.
void setupPacketAvx512(const float* columnX, const float* rowY,
                       const Eigen::Matrix3f& toWorld, int columns, int rows,
                       RTCRayHit16& packet, int valid[kPacket]) {
  const __m512 x = _mm512_maskz_broadcast_f32x4(kAll, _mm_loadu_ps(columnX));
  const __m512 y = _mm512_maskz_permutexvar_ps(kAll, 
      _mm512_set_epi32(3, 3, 3, 3, 2, 2, 2, 2, 1, 1, 1, 1, 0, 0, 0, 0),
      _mm512_maskz_broadcast_f32x4(kAll, _mm_loadu_ps(rowY)));
  // world direction = x * right + y * up - back (columns of toWorld)
  float* directions[3] = {packet.ray.dir_x, packet.ray.dir_y, packet.ray.dir_z};
  for (int axis = 0; axis < 3; ++axis) {
    const __m512 d = _mm512_fmadd_ps(
        x, _mm512_set1_ps(toWorld(axis, 0)),
        _mm512_fmsub_ps(y, _mm512_set1_ps(toWorld(axis, 1)),
                        _mm512_set1_ps(toWorld(axis, 2))));
    _mm512_store_ps(directions[axis], d);
  }
  _mm512_store_ps(packet.ray.tfar, _mm512_set1_ps(std::numeric_limits<float>::infinity()));
  _mm512_store_si512(packet.hit.geomID,
                     _mm512_set1_epi32(static_cast<int>(RTC_INVALID_GEOMETRY_ID)));
  const __m512i lane = _mm512_set_epi32(15, 14, 13, 12, 11, 10, 9, 8, 7, 6, 5, 4, 3, 2, 1, 0);
  const __m512i column = _mm512_and_si512(lane, _mm512_set1_epi32(kTile - 1));
  const __m512i row = _mm512_maskz_srli_epi32(kAll, lane, 2);
  const __mmask16 inside =
      _mm512_cmplt_epi32_mask(column, _mm512_set1_epi32(columns)) &
      _mm512_cmplt_epi32_mask(row, _mm512_set1_epi32(rows));
  _mm512_store_si512(valid, _mm512_maskz_mov_epi32(inside, _mm512_set1_epi32(-1)));
}

#if defined(__clang__)
#pragma clang attribute pop
#else
#pragma GCC pop_options
#endif

// ---------------------------------------------------------------------------
// EmbreeRenderer
// ---------------------------------------------------------------------------

class EmbreeRenderer final : public Renderer {
 public:
  EmbreeRenderer(const TriangleMesh& mesh, const RayTracer& rayTracer)
      : Renderer("EmbreeRenderer", mesh),
        mesh_(mesh),
        scene_(static_cast<RTCScene>(rayTracer.embreeScene())) {
    for (const Texture& texture : mesh.textures)
      textures_.push_back({texture.rgb.data(), texture.width, texture.height});
    // the packet paths need AVX-512F; VLN_EMBREE_SHADING=scalar forces the
    // portable path, which renders the same bits (tests compare the two)
    const char* forced = std::getenv("VLN_EMBREE_SHADING");
    const bool scalarOnly = forced != nullptr && std::string_view(forced) == "scalar";
    avx512_ = !scalarOnly && cpuHasAvx512();
    if (avx512_) packedTextures_ = packTextures(mesh);
  }

 private:
  void updateRayTable(const CameraIntrinsics& camera);
  void render(const CameraPose& pose, const CameraIntrinsics& camera,
              unsigned outputs, uint8_t* rgb, float* depth,
              int32_t* objects) override;
  void shadePacket(const RTCHit16& hits, unsigned hitMask,
                   uint32_t packed[kPacket]) const;

  const TriangleMesh& mesh_;
  RTCScene scene_;
  // built on the first colour render: depth-only renderers never pay for it
  std::vector<TriangleShade> shadeTable_;
  std::vector<TextureView> textures_;
  // packet ray setup and shading with AVX-512F (the CPU has it and the
  // scalar path is not forced); shading also needs the textures to fit the
  // gathers' 32-bit offsets
  bool avx512_ = false;
  std::optional<PackedTextures> packedTextures_;
  // camera-frame ray slopes per column (x) and row (y) of the last intrinsics
  CameraIntrinsics tableCamera_{0, 0, 0.0f};
  std::vector<float> columnX_;
  std::vector<float> rowY_;
};

void EmbreeRenderer::updateRayTable(const CameraIntrinsics& camera) {
  if (camera.width == tableCamera_.width &&
      camera.height == tableCamera_.height &&
      camera.hfov_deg == tableCamera_.hfov_deg)
    return;
  // tiles overhang the image; padded entries repeat the last pixel so the
  // masked-off lanes still carry finite rays
  const int paddedWidth = (camera.width + kTile - 1) / kTile * kTile;
  const int paddedHeight = (camera.height + kTile - 1) / kTile * kTile;
  columnX_.resize(paddedWidth);
  rowY_.resize(paddedHeight);
  for (int i = 0; i < paddedWidth; ++i)
    columnX_[i] = pixelDirection(camera, static_cast<float>(std::min(i, camera.width - 1)), 0.0f).x();
  for (int j = 0; j < paddedHeight; ++j)
    rowY_[j] = pixelDirection(camera, 0.0f, static_cast<float>(std::min(j, camera.height - 1))).y();
  tableCamera_ = camera;
}

void EmbreeRenderer::render(const CameraPose& pose,
                            const CameraIntrinsics& camera, unsigned outputs,
                            uint8_t* rgb, float* depth, int32_t* objects) {
  FlushDenormalsScope flushDenormals;
  updateRayTable(camera);
  if ((outputs & kColor) && shadeTable_.empty()) shadeTable_ = buildShadeTable(mesh_);
  const Eigen::Matrix3f rotation = cameraToWorld(pose);
  const int width = camera.width;
  const int height = camera.height;
  const auto& triangleObject = mesh_.triangle_object;

  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  context.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
  RTCRayHit16 packet;
  alignas(64) int valid[kPacket];
  // Embree only writes tfar and the hit, so the rest of the rays is set once
  for (int k = 0; k < kPacket; ++k) {
    packet.ray.org_x[k] = pose.eye.x();
    packet.ray.org_y[k] = pose.eye.y();
    packet.ray.org_z[k] = pose.eye.z();
    packet.ray.tnear[k] = 0.0f;
    packet.ray.time[k] = 0.0f;
    packet.ray.mask[k] = std::numeric_limits<unsigned>::max();
    packet.ray.id[k] = static_cast<unsigned>(k);
    packet.ray.flags[k] = 0;
  }

  for (int tileY = 0; tileY < height; tileY += kTile) {
    for (int tileX = 0; tileX < width; tileX += kTile) {
      // primary rays of one 4x4 tile; directions have unit length along the
      // optical axis, so the hit distance t is the z-depth itself
      if (avx512_) {
        setupPacketAvx512(columnX_.data() + tileX, rowY_.data() + tileY, rotation,
                          width - tileX, height - tileY, packet, valid);
      } else {
        setupPacketPortable(columnX_.data() + tileX, rowY_.data() + tileY,
                            rotation, width - tileX, height - tileY, packet,
                            valid);
      }
      rtcIntersect16(valid, scene_, &context, &packet);

      unsigned hitMask = 0;
      for (int k = 0; k < kPacket; ++k)
        if (valid[k] != 0 && packet.hit.geomID[k] != RTC_INVALID_GEOMETRY_ID)
          hitMask |= 1u << k;
      alignas(64) uint32_t colors[kPacket];
      if (outputs & kColor) shadePacket(packet.hit, hitMask, colors);

      // write the tile's rows (the last tiles may overhang the image)
      const int rows = std::min(kTile, height - tileY);
      const int columns = std::min(kTile, width - tileX);
      for (int row = 0; row < rows; ++row) {
        const size_t first = static_cast<size_t>(tileY + row) * static_cast<size_t>(width) +
                             static_cast<size_t>(tileX);
        for (int column = 0; column < columns; ++column) {
          const int k = row * kTile + column;
          const bool hit = (hitMask >> k) & 1u;
          const size_t pixel = first + static_cast<size_t>(column);
          if (outputs & kDepth) depth[pixel] = hit ? packet.ray.tfar[k] : 0.0f;
          if (outputs & kObject)
            objects[pixel] = (hit && !triangleObject.empty())
                                 ? triangleObject[packet.hit.primID[k]]
                                 : -1;
          if (outputs & kColor) {
            uint8_t* out = rgb + 3 * pixel;
            out[0] = static_cast<uint8_t>(colors[k]);
            out[1] = static_cast<uint8_t>(colors[k] >> 8);
            out[2] = static_cast<uint8_t>(colors[k] >> 16);
          }
        }
      }
    }
  }
}

void EmbreeRenderer::shadePacket(const RTCHit16& hits, unsigned hitMask,
                                 uint32_t packed[kPacket]) const {
  if (packedTextures_) {
    shadePacketAvx512(shadeTable_.data(), *packedTextures_, hits, hitMask, packed);
    return;
  }
  for (int k = 0; k < kPacket; ++k) {
    packed[k] = (hitMask >> k) & 1u
                    ? shadePortable(shadeTable_[hits.primID[k]], hits.u[k],
                                    hits.v[k], textures_)
                    : 0u;
  }
}

}  // namespace

std::unique_ptr<Renderer> createEmbreeRenderer(const TriangleMesh& mesh,
                                               const RayTracer& rayTracer) {
  return std::make_unique<EmbreeRenderer>(mesh, rayTracer);
}

}  // namespace vln::sim
