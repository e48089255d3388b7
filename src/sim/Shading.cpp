#include "sim/Shading.h"

#include <immintrin.h>

#include <array>
#include <cmath>
#include <cstddef>
#include <limits>

#include "sim/Mesh.h"

namespace vln::sim {

namespace {

// floor() for |x| < 2^31 without SSE4.1's roundss: the baseline x86-64 build
// would otherwise call into libm for every texel coordinate
inline int floorToInt(float x) {
  const int i = static_cast<int>(x);
  return i - (x < static_cast<float>(i) ? 1 : 0);
}

// GL's float-to-unorm conversion as the vector paths do it: max(c, 0) and
// min(c, 1) with SSE's rules (a NaN becomes 0), scale, round to nearest.
inline uint32_t unormByte(float c) {
  c = c > 0.0f ? c : 0.0f;
  c = c < 1.0f ? c : 1.0f;
  return static_cast<uint32_t>(static_cast<int32_t>(std::fma(c, 255.0f, 0.5f)));
}

// The portable rule for one hit (HitShader).
VLN_PORTABLE_FMA uint32_t shadeHit(const TriangleShade& t, float u, float v,
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

// The shading table of `mesh` (see TriangleShade), one record per triangle.
std::vector<TriangleShade> buildShadeTable(const TriangleMesh& mesh) {
  std::vector<TriangleShade> table(mesh.triangleCount());
  for (size_t t = 0; t < table.size(); ++t) {
    const uint32_t* corner = mesh.indices.data() + 3 * t;
    std::array<float, 3> base{1.0f, 1.0f, 1.0f};
    int texture = -1;
    const int material =
        mesh.triangle_material.empty() ? -1 : mesh.triangle_material[t];
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

std::vector<TextureView> textureViews(const TriangleMesh& mesh) {
  std::vector<TextureView> views;
  views.reserve(mesh.textures.size());
  for (const Texture& texture : mesh.textures)
    views.push_back({texture.rgb.data(), texture.width, texture.height});
  return views;
}

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
    packed.texels.insert(packed.texels.end(), texture.rgb.begin(),
                         texture.rgb.end());
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

bool cpuHasAvx2Fma() {
  __builtin_cpu_init();
  return __builtin_cpu_supports("avx2") != 0 &&
         __builtin_cpu_supports("fma") != 0;
}

// Everything up to the matching pop_options is compiled for AVX2 + FMA
// (lambdas included) and only called after cpuHasAvx2Fma().
#if defined(__clang__)
#pragma clang attribute push(__attribute__((target("avx2,fma"))), \
                             apply_to = function)
#else
#pragma GCC push_options
#pragma GCC target("avx2,fma")
#endif

// shadeHit() for eight lanes at once: every operation here has its twin
// there, in the same order (fused where that one calls std::fma). Change
// both.
void shade8Avx2(const TriangleShade* table, const PackedTextures& textures,
                const uint32_t* triangles, const float* uIn, const float* vIn,
                unsigned mask, uint32_t colors[8]) {
  const __m256i laneBit = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
  const __m256i lanes = _mm256_cmpeq_epi32(
      _mm256_and_si256(_mm256_set1_epi32(static_cast<int>(mask)), laneBit),
      laneBit);
  const __m256 lanesf = _mm256_castsi256_ps(lanes);
  const __m256i zero = _mm256_setzero_si256();
  const __m256 zerof = _mm256_setzero_ps();
  // plain loads (all eight entries are readable): a masked load cannot take
  // its data from the caller's stores still in flight, and waits for them;
  // lanes outside `mask` only feed masked gathers and the masked result
  const __m256i primitive =
      _mm256_loadu_si256(reinterpret_cast<const __m256i*>(triangles));
  const __m256 u = _mm256_loadu_ps(uIn);
  const __m256 v = _mm256_loadu_ps(vIn);
  // most runs of eight pixels show one triangle (74% in a house's
  // panoramas) or two or three (23%): broadcasting their records and
  // blending them by lane then replaces the sixteen gathers of the fields
  constexpr int kBroadcastMost = 3;
  uint32_t distinct[kBroadcastMost] = {0u, 0u, 0u};
  __m256i distinctLanes[kBroadcastMost];
  int distinctCount = 0;
  __m256i remaining = lanes;
  while (!_mm256_testz_si256(remaining, remaining) &&
         distinctCount < kBroadcastMost) {
    const auto lane = static_cast<unsigned>(__builtin_ctz(static_cast<unsigned>(
        _mm256_movemask_ps(_mm256_castsi256_ps(remaining)))));
    distinct[distinctCount] = triangles[lane];
    const __m256i same = _mm256_and_si256(
        remaining,
        _mm256_cmpeq_epi32(
            primitive, _mm256_set1_epi32(static_cast<int>(triangles[lane]))));
    distinctLanes[distinctCount++] = same;
    remaining = _mm256_andnot_si256(same, remaining);
  }
  const bool broadcast = _mm256_testz_si256(remaining, remaining) != 0;
  const __m256i record = _mm256_slli_epi32(primitive, 4);
  const auto* base = reinterpret_cast<const float*>(table);
  auto field = [&](int index) {
    if (broadcast) {
      __m256 value =
          _mm256_set1_ps(base[16 * static_cast<size_t>(distinct[0]) + index]);
      for (int d = 1; d < distinctCount; ++d)
        value = _mm256_blendv_ps(
            value,
            _mm256_set1_ps(base[16 * static_cast<size_t>(distinct[d]) + index]),
            _mm256_castsi256_ps(distinctLanes[d]));
      return value;
    }
    return _mm256_mask_i32gather_ps(
        zerof, base, _mm256_add_epi32(record, _mm256_set1_epi32(index)), lanesf,
        4);
  };
  __m256 r =
      _mm256_fmadd_ps(v, field(8), _mm256_fmadd_ps(u, field(4), field(0)));
  __m256 g =
      _mm256_fmadd_ps(v, field(9), _mm256_fmadd_ps(u, field(5), field(1)));
  __m256 b =
      _mm256_fmadd_ps(v, field(10), _mm256_fmadd_ps(u, field(6), field(2)));
  const __m256i texture = _mm256_castps_si256(field(3));
  const __m256i textured = _mm256_and_si256(
      lanes, _mm256_cmpgt_epi32(texture, _mm256_set1_epi32(-1)));

  if (!_mm256_testz_si256(textured, textured)) {
    const __m256 texturedf = _mm256_castsi256_ps(textured);
    // uv, sanitised and wrapped into [0, 1)
    __m256 s =
        _mm256_fmadd_ps(v, field(14), _mm256_fmadd_ps(u, field(12), field(7)));
    __m256 t =
        _mm256_fmadd_ps(v, field(15), _mm256_fmadd_ps(u, field(13), field(11)));
    const __m256 absMask = _mm256_castsi256_ps(_mm256_set1_epi32(0x7FFFFFFF));
    const __m256 limit = _mm256_set1_ps(1e6f);
    s = _mm256_and_ps(
        _mm256_cmp_ps(_mm256_and_ps(s, absMask), limit, _CMP_LT_OQ), s);
    t = _mm256_and_ps(
        _mm256_cmp_ps(_mm256_and_ps(t, absMask), limit, _CMP_LT_OQ), t);
    s = _mm256_sub_ps(s, _mm256_floor_ps(s));
    t = _mm256_sub_ps(t, _mm256_floor_ps(t));
    // per-texture size and offset, broadcast and blended as the fields (a
    // triangle without a texture has no entry: its lanes are not textured,
    // so any value does)
    auto textureField = [&](const std::vector<int32_t>& values) {
      if (broadcast) {
        auto entry = [&](uint32_t triangle) {
          const int32_t id = table[triangle].texture;
          return _mm256_set1_epi32(id >= 0 ? values[static_cast<size_t>(id)]
                                           : 0);
        };
        __m256i value = entry(distinct[0]);
        for (int d = 1; d < distinctCount; ++d)
          value =
              _mm256_blendv_epi8(value, entry(distinct[d]), distinctLanes[d]);
        return value;
      }
      return _mm256_mask_i32gather_epi32(zero, values.data(), texture, textured,
                                         4);
    };
    const __m256i width = textureField(textures.width);
    const __m256i height = textureField(textures.height);
    const __m256i offset = textureField(textures.offset);
    const __m256 half = _mm256_set1_ps(0.5f);
    const __m256 x = _mm256_fmsub_ps(s, _mm256_cvtepi32_ps(width), half);
    const __m256 y = _mm256_fmsub_ps(t, _mm256_cvtepi32_ps(height), half);
    const __m256 x0f = _mm256_floor_ps(x);
    const __m256 y0f = _mm256_floor_ps(y);
    const __m256 fx = _mm256_sub_ps(x, x0f);
    const __m256 fy = _mm256_sub_ps(y, y0f);
    // texel indices wrapped with one comparison each
    const __m256i one = _mm256_set1_epi32(1);
    __m256i x0 = _mm256_cvttps_epi32(x0f);
    __m256i y0 = _mm256_cvttps_epi32(y0f);
    __m256i x1 = _mm256_add_epi32(x0, one);
    __m256i y1 = _mm256_add_epi32(y0, one);
    x0 = _mm256_add_epi32(
        x0, _mm256_and_si256(_mm256_cmpgt_epi32(zero, x0), width));
    y0 = _mm256_add_epi32(
        y0, _mm256_and_si256(_mm256_cmpgt_epi32(zero, y0), height));
    x1 = _mm256_sub_epi32(
        x1, _mm256_and_si256(
                _mm256_cmpgt_epi32(x1, _mm256_sub_epi32(width, one)), width));
    y1 = _mm256_sub_epi32(
        y1, _mm256_and_si256(
                _mm256_cmpgt_epi32(y1, _mm256_sub_epi32(height, one)), height));
    // byte addresses of the four texels
    const __m256i three = _mm256_set1_epi32(3);
    const __m256i row0 = _mm256_mullo_epi32(y0, width);
    const __m256i row1 = _mm256_mullo_epi32(y1, width);
    auto address = [&](__m256i row, __m256i column) {
      return _mm256_add_epi32(
          offset, _mm256_mullo_epi32(_mm256_add_epi32(row, column), three));
    };
    const auto* texels = reinterpret_cast<const int*>(textures.texels.data());
    auto fetch = [&](__m256i at) {
      return _mm256_mask_i32gather_epi32(zero, texels, at, textured, 1);
    };
    const __m256i t00 = fetch(address(row0, x0));
    const __m256i t10 = fetch(address(row0, x1));
    const __m256i t01 = fetch(address(row1, x0));
    const __m256i t11 = fetch(address(row1, x1));
    const __m256 inv255 = _mm256_set1_ps(1.0f / 255.0f);
    const __m256 onef = _mm256_set1_ps(1.0f);
    const __m256 gx = _mm256_sub_ps(onef, fx);
    const __m256 gy = _mm256_sub_ps(onef, fy);
    const __m256 w00 = _mm256_mul_ps(_mm256_mul_ps(gx, gy), inv255);
    const __m256 w10 = _mm256_mul_ps(_mm256_mul_ps(fx, gy), inv255);
    const __m256 w01 = _mm256_mul_ps(_mm256_mul_ps(gx, fy), inv255);
    const __m256 w11 = _mm256_mul_ps(_mm256_mul_ps(fx, fy), inv255);
    const __m256i byteMask = _mm256_set1_epi32(0xFF);
    auto channel = [&](int shift) {
      auto value = [&](__m256i texel) {
        return _mm256_cvtepi32_ps(
            _mm256_and_si256(_mm256_srli_epi32(texel, shift), byteMask));
      };
      return _mm256_fmadd_ps(
          w11, value(t11),
          _mm256_fmadd_ps(w01, value(t01),
                          _mm256_fmadd_ps(w10, value(t10),
                                          _mm256_mul_ps(w00, value(t00)))));
    };
    r = _mm256_blendv_ps(r, _mm256_mul_ps(r, channel(0)), texturedf);
    g = _mm256_blendv_ps(g, _mm256_mul_ps(g, channel(8)), texturedf);
    b = _mm256_blendv_ps(b, _mm256_mul_ps(b, channel(16)), texturedf);
  }

  // GL's float-to-unorm conversion (a NaN becomes 0: max returns its second
  // operand then), then r | g << 8 | b << 16
  const __m256 scale = _mm256_set1_ps(255.0f);
  const __m256 half = _mm256_set1_ps(0.5f);
  const __m256 onef = _mm256_set1_ps(1.0f);
  auto toByte = [&](__m256 c) {
    c = _mm256_min_ps(_mm256_max_ps(c, zerof), onef);
    return _mm256_cvttps_epi32(_mm256_fmadd_ps(c, scale, half));
  };
  const __m256i rgb = _mm256_or_si256(
      toByte(r), _mm256_or_si256(_mm256_slli_epi32(toByte(g), 8),
                                 _mm256_slli_epi32(toByte(b), 16)));
  _mm256_storeu_si256(reinterpret_cast<__m256i*>(colors),
                      _mm256_and_si256(rgb, lanes));
}

#if defined(__clang__)
#pragma clang attribute pop
#else
#pragma GCC pop_options
#endif

// Everything up to the matching pop_options is compiled for AVX-512F + FMA
// (lambdas included) and only called after cpuHasAvx512().
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

// shadeHit() for sixteen lanes at once (Embree's packets; the portable path
// takes ~100 instructions per textured pixel, this ~15). Lanes outside
// `hitMask` get 0. Every operation here has its twin there: change both.
void shade16Avx512(const TriangleShade* table, const PackedTextures& textures,
                   const uint32_t* triangles, const float* uIn,
                   const float* vIn, unsigned hitMask, uint32_t packed[16]) {
  const __mmask16 lanes = static_cast<__mmask16>(hitMask);
  const __m512i zero = _mm512_setzero_si512();
  const __m512 zerof = _mm512_setzero_ps();
  // fields of each lane's TriangleShade record (16 floats per record). In
  // most packets every lane hits the same large triangle (walls, floors);
  // broadcasting its record then replaces 16 gathers, the dominant cost.
  const __m512i primitive = _mm512_maskz_loadu_epi32(lanes, triangles);
  const unsigned firstLane =
      static_cast<unsigned>(__builtin_ctz(hitMask | 0x10000u));
  const uint32_t firstPrimitive = firstLane < 16 ? triangles[firstLane] : 0u;
  const bool uniform =
      _mm512_mask_cmpneq_epi32_mask(
          lanes, primitive,
          _mm512_set1_epi32(static_cast<int>(firstPrimitive))) == 0;
  const __m512i record = _mm512_maskz_slli_epi32(kAll, primitive, 4);
  const auto* base = reinterpret_cast<const float*>(table);
  const float* uniformRecord = base + 16 * static_cast<size_t>(firstPrimitive);
  auto field = [&](int index) {
    if (uniform) return _mm512_set1_ps(uniformRecord[index]);
    return _mm512_mask_i32gather_ps(
        zerof, lanes, _mm512_add_epi32(record, _mm512_set1_epi32(index)), base,
        4);
  };
  const __m512 u = _mm512_maskz_loadu_ps(lanes, uIn);
  const __m512 v = _mm512_maskz_loadu_ps(lanes, vIn);
  __m512 r =
      _mm512_fmadd_ps(v, field(8), _mm512_fmadd_ps(u, field(4), field(0)));
  __m512 g =
      _mm512_fmadd_ps(v, field(9), _mm512_fmadd_ps(u, field(5), field(1)));
  __m512 b =
      _mm512_fmadd_ps(v, field(10), _mm512_fmadd_ps(u, field(6), field(2)));
  const __m512i texture = _mm512_castps_si512(field(3));
  const __mmask16 textured = _mm512_mask_cmpge_epi32_mask(lanes, texture, zero);

  if (textured != 0) {
    // uv, sanitised and wrapped into [0, 1) as in sampleBilinear()
    __m512 s =
        _mm512_fmadd_ps(v, field(14), _mm512_fmadd_ps(u, field(12), field(7)));
    __m512 t =
        _mm512_fmadd_ps(v, field(15), _mm512_fmadd_ps(u, field(13), field(11)));
    const __m512 limit = _mm512_set1_ps(1e6f);
    s = _mm512_maskz_mov_ps(
        _mm512_cmp_ps_mask(_mm512_abs_ps(s), limit, _CMP_LT_OQ), s);
    t = _mm512_maskz_mov_ps(
        _mm512_cmp_ps_mask(_mm512_abs_ps(t), limit, _CMP_LT_OQ), t);
    constexpr int kFloor = _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC;
    s = _mm512_sub_ps(s, _mm512_maskz_roundscale_ps(kAll, s, kFloor));
    t = _mm512_sub_ps(t, _mm512_maskz_roundscale_ps(kAll, t, kFloor));
    // per-texture size and offset, broadcast when all lanes share a triangle
    auto textureField = [&](const std::vector<int32_t>& values) {
      if (uniform)
        return _mm512_set1_epi32(
            values[static_cast<size_t>(table[firstPrimitive].texture)]);
      return _mm512_mask_i32gather_epi32(zero, textured, texture, values.data(),
                                         4);
    };
    const __m512i width = textureField(textures.width);
    const __m512i height = textureField(textures.height);
    const __m512i offset = textureField(textures.offset);
    const __m512 half = _mm512_set1_ps(0.5f);
    const __m512 x =
        _mm512_fmsub_ps(s, _mm512_maskz_cvtepi32_ps(kAll, width), half);
    const __m512 y =
        _mm512_fmsub_ps(t, _mm512_maskz_cvtepi32_ps(kAll, height), half);
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
    x0 =
        _mm512_mask_add_epi32(x0, _mm512_cmplt_epi32_mask(x0, zero), x0, width);
    y0 = _mm512_mask_add_epi32(y0, _mm512_cmplt_epi32_mask(y0, zero), y0,
                               height);
    x1 = _mm512_mask_sub_epi32(x1, _mm512_cmpge_epi32_mask(x1, width), x1,
                               width);
    y1 = _mm512_mask_sub_epi32(y1, _mm512_cmpge_epi32_mask(y1, height), y1,
                               height);
    // byte addresses of the four texels
    const __m512i three = _mm512_set1_epi32(3);
    const __m512i row0 = _mm512_mullo_epi32(y0, width);
    const __m512i row1 = _mm512_mullo_epi32(y1, width);
    auto address = [&](__m512i row, __m512i column) {
      return _mm512_add_epi32(
          offset, _mm512_mullo_epi32(_mm512_add_epi32(row, column), three));
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
        return _mm512_maskz_cvtepi32_ps(
            kAll,
            _mm512_and_si512(_mm512_maskz_srli_epi32(
                                 kAll, texel, static_cast<unsigned>(shift)),
                             byteMask));
      };
      return _mm512_fmadd_ps(
          w11, value(t11),
          _mm512_fmadd_ps(w01, value(t01),
                          _mm512_fmadd_ps(w10, value(t10),
                                          _mm512_mul_ps(w00, value(t00)))));
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

#if defined(__clang__)
#pragma clang attribute pop
#else
#pragma GCC pop_options
#endif

}  // namespace

bool cpuHasAvx512() {
  __builtin_cpu_init();
  return __builtin_cpu_supports("avx512f") != 0;
}

HitShader::HitShader(const TriangleMesh& mesh, bool vectorized)
    : table_(buildShadeTable(mesh)), textures_(textureViews(mesh)) {
  if (vectorized) packed_ = packTextures(mesh);
  avx2_ = packed_.has_value() && cpuHasAvx2Fma();
  avx512_ = packed_.has_value() && cpuHasAvx512();
}

void HitShader::shade16(const uint32_t* triangles, const float* u,
                        const float* v, unsigned mask,
                        uint32_t colors[16]) const {
  mask &= 0xFFFFu;
  if (avx512_) {
    shade16Avx512(table_.data(), *packed_, triangles, u, v, mask, colors);
    return;
  }
  shade8(triangles, u, v, mask, colors);
  shade8(triangles + 8, u + 8, v + 8, mask >> 8, colors + 8);
}

void HitShader::shade8(const uint32_t* triangles, const float* u,
                       const float* v, unsigned mask,
                       uint32_t colors[8]) const {
  mask &= 0xFFu;
  if (avx2_) {
    shade8Avx2(table_.data(), *packed_, triangles, u, v, mask, colors);
    return;
  }
  for (int k = 0; k < 8; ++k)
    colors[k] = (mask >> k) & 1u
                    ? shadeHit(table_[triangles[k]], u[k], v[k], textures_)
                    : 0u;
}

}  // namespace vln::sim
