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
// AVX-512 ray set-up of a whole packet
// ---------------------------------------------------------------------------

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
    // the packet ray set-up needs AVX-512F (shading: HitShader's vector
    // paths); VLN_EMBREE_SHADING=scalar forces the portable paths of both,
    // which render the same bits (tests compare them)
    const char* forced = std::getenv("VLN_EMBREE_SHADING");
    scalarOnly_ = forced != nullptr && std::string_view(forced) == "scalar";
    avx512_ = !scalarOnly_ && cpuHasAvx512();
  }

 private:
  void updateRayTable(const CameraIntrinsics& camera);
  void render(const CameraPose& pose, const CameraIntrinsics& camera,
              unsigned outputs, uint8_t* rgb, float* depth,
              int32_t* objects) override;

  const TriangleMesh& mesh_;
  RTCScene scene_;
  // built on the first colour render: depth-only renderers never pay for it
  std::optional<HitShader> shader_;
  // the portable paths are forced; else packet ray set-up with AVX-512F
  // where the CPU has it
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
  // tiles overhang the image: whole tiles of slopes
  PixelSlopes slopes = pixelSlopes(camera, kTile);
  columnX_ = std::move(slopes.columnX);
  rowY_ = std::move(slopes.rowY);
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
      if (outputs & kColor)
        shader_->shade16(packet.hit.primID, packet.hit.u, packet.hit.v, hitMask,
                         colors);

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
          if (outputs & kColor) writeColor(colors[k], rgb + 3 * pixel);
        }
      }
    }
  }
}

}  // namespace

std::unique_ptr<Renderer> createEmbreeRenderer(const TriangleMesh& mesh,
                                               const RayTracer& rayTracer) {
  return std::make_unique<EmbreeRenderer>(mesh, rayTracer);
}

}  // namespace vln::sim
