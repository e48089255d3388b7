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
#include "sim/Shading.h"

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
    // the packet paths need AVX-512F (shading eight hits at a time, AVX2);
    // VLN_EMBREE_SHADING=scalar forces the portable paths, which render the
    // same bits (tests compare them)
    const char* forced = std::getenv("VLN_EMBREE_SHADING");
    scalarOnly_ = forced != nullptr && std::string_view(forced) == "scalar";
    avx512_ = !scalarOnly_ && cpuHasAvx512();
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
  std::optional<HitShader> shader_;
  // packet ray setup and shading with AVX-512F (the CPU has it and the
  // scalar path is not forced); shading also needs the textures to fit the
  // gathers' 32-bit offsets
  bool scalarOnly_ = false;
  bool avx512_ = false;
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
  if ((outputs & kColor) && !shader_) shader_.emplace(mesh_, !scalarOnly_);
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
  if (avx512_ && shader_->packedTextures() != nullptr) {
    shadePacketAvx512(shader_->table().data(), *shader_->packedTextures(), hits,
                      hitMask, packed);
    return;
  }
  // two halves of eight lanes
  for (int half = 0; half < kPacket; half += 8)
    shader_->shade8(hits.primID + half, hits.u + half, hits.v + half,
                    hitMask >> half, packed + half);
}

}  // namespace

std::unique_ptr<Renderer> createEmbreeRenderer(const TriangleMesh& mesh,
                                               const RayTracer& rayTracer) {
  return std::make_unique<EmbreeRenderer>(mesh, rayTracer);
}

}  // namespace vln::sim
