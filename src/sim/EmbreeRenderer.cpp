#include "sim/EmbreeRenderer.h"

#include <embree3/rtcore.h>
#include <pmmintrin.h>
#include <xmmintrin.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "common/Check.h"
#include "sim/Mesh.h"
#include "sim/RayTracer.h"

namespace vln::sim {

namespace {

// Which images one pass writes (a bit set).
enum Output : unsigned { kColor = 1u, kDepth = 2u, kObject = 4u };

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

// A material flattened for shading: base colour and texture (or null).
struct ShadeMaterial {
  float r = 1.0f;
  float g = 1.0f;
  float b = 1.0f;
  const Texture* texture = nullptr;
};

// Texel index with GL_REPEAT semantics.
inline int wrapIndex(int i, int size) {
  const int m = i % size;
  return m < 0 ? m + size : m;
}

// Bilinear lookup with wrap, as GL_LINEAR + GL_REPEAT without mipmaps: texel
// centres at (i + 0.5) / size, row 0 at v = 0 (the rasteriser uploads the
// rows in the same order). Returns colour in [0, 1].
inline void sampleBilinear(const Texture& texture, float s, float t,
                           float out[3]) {
  if (!std::isfinite(s)) s = 0.0f;
  if (!std::isfinite(t)) t = 0.0f;
  // wrapping the coordinate first keeps the float-to-int conversion in range
  s -= std::floor(s);
  t -= std::floor(t);
  const float x = s * static_cast<float>(texture.width) - 0.5f;
  const float y = t * static_cast<float>(texture.height) - 0.5f;
  const float x0f = std::floor(x);
  const float y0f = std::floor(y);
  const float fx = x - x0f;
  const float fy = y - y0f;
  const int x0 = wrapIndex(static_cast<int>(x0f), texture.width);
  const int x1 = wrapIndex(static_cast<int>(x0f) + 1, texture.width);
  const int y0 = wrapIndex(static_cast<int>(y0f), texture.height);
  const int y1 = wrapIndex(static_cast<int>(y0f) + 1, texture.height);
  const uint8_t* row0 = texture.rgb.data() + static_cast<size_t>(y0) *
                                                 static_cast<size_t>(texture.width) * 3;
  const uint8_t* row1 = texture.rgb.data() + static_cast<size_t>(y1) *
                                                 static_cast<size_t>(texture.width) * 3;
  const float w00 = (1.0f - fx) * (1.0f - fy);
  const float w10 = fx * (1.0f - fy);
  const float w01 = (1.0f - fx) * fy;
  const float w11 = fx * fy;
  for (int c = 0; c < 3; ++c) {
    out[c] = (w00 * row0[3 * x0 + c] + w10 * row0[3 * x1 + c] +
              w01 * row1[3 * x0 + c] + w11 * row1[3 * x1 + c]) *
             (1.0f / 255.0f);
  }
}

inline uint8_t toUnorm8(float value) {
  // GL's float-to-unorm conversion: clamp, scale, round to nearest
  return static_cast<uint8_t>(std::clamp(value, 0.0f, 1.0f) * 255.0f + 0.5f);
}

// ---------------------------------------------------------------------------
// EmbreeRenderer
// ---------------------------------------------------------------------------

class EmbreeRenderer final : public Renderer {
 public:
  EmbreeRenderer(const TriangleMesh& mesh, const RayTracer& rayTracer)
      : mesh_(mesh), scene_(static_cast<RTCScene>(rayTracer.embreeScene())) {
    // slot 0 is the default material of triangles without one
    materials_.emplace_back();
    for (const Material& m : mesh.materials) {
      ShadeMaterial shade;
      shade.r = m.base_color[0];
      shade.g = m.base_color[1];
      shade.b = m.base_color[2];
      if (m.texture >= 0) shade.texture = &mesh.textures[m.texture];
      materials_.push_back(shade);
    }
  }

  void renderRgb(const CameraPose& pose, const CameraIntrinsics& camera,
                 std::span<uint8_t> rgb) override {
    checkRenderArgs("EmbreeRenderer::renderRgb()", pose, camera, rgb.size(),
                    3);
    render(pose, camera, kColor, rgb.data(), nullptr, nullptr);
  }

  void renderDepth(const CameraPose& pose, const CameraIntrinsics& camera,
                   std::span<float> depth) override {
    checkRenderArgs("EmbreeRenderer::renderDepth()", pose, camera,
                    depth.size(), 1);
    render(pose, camera, kDepth, nullptr, depth.data(), nullptr);
  }

  void renderRgbDepth(const CameraPose& pose, const CameraIntrinsics& camera,
                      std::span<uint8_t> rgb, std::span<float> depth) override {
    checkRenderArgs("EmbreeRenderer::renderRgbDepth() rgb", pose, camera,
                    rgb.size(), 3);
    checkRenderArgs("EmbreeRenderer::renderRgbDepth() depth", pose, camera,
                    depth.size(), 1);
    render(pose, camera, kColor | kDepth, rgb.data(), depth.data(), nullptr);
  }

  void renderSemantic(const CameraPose& pose, const CameraIntrinsics& camera,
                      std::span<int32_t> objectIds) override {
    checkRenderArgs("EmbreeRenderer::renderSemantic()", pose, camera,
                    objectIds.size(), 1);
    render(pose, camera, kObject, nullptr, nullptr, objectIds.data());
  }

 private:
  void updateRayTable(const CameraIntrinsics& camera);
  void render(const CameraPose& pose, const CameraIntrinsics& camera,
              unsigned outputs, uint8_t* rgb, float* depth, int32_t* objects);
  void shade(unsigned triangle, float u, float v, uint8_t* out) const;

  const TriangleMesh& mesh_;
  RTCScene scene_;
  std::vector<ShadeMaterial> materials_;
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
  const Eigen::Matrix3f rotation = cameraToWorld(pose);
  const Vec3f right = rotation.col(0);
  const Vec3f up = rotation.col(1);
  const Vec3f forward = -rotation.col(2);
  const int width = camera.width;
  const int height = camera.height;
  const auto& triangleObject = mesh_.triangle_object;

  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  context.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
  RTCRayHit16 packet;
  alignas(64) int valid[kPacket];

  for (int tileY = 0; tileY < height; tileY += kTile) {
    for (int tileX = 0; tileX < width; tileX += kTile) {
      // primary rays of one 4x4 tile; directions have unit length along the
      // optical axis, so the hit distance t is the z-depth itself
      for (int k = 0; k < kPacket; ++k) {
        const int i = tileX + k % kTile;
        const int j = tileY + k / kTile;
        valid[k] = (i < width && j < height) ? -1 : 0;
        const Vec3f dir = columnX_[i] * right + rowY_[j] * up + forward;
        packet.ray.org_x[k] = pose.eye.x();
        packet.ray.org_y[k] = pose.eye.y();
        packet.ray.org_z[k] = pose.eye.z();
        packet.ray.dir_x[k] = dir.x();
        packet.ray.dir_y[k] = dir.y();
        packet.ray.dir_z[k] = dir.z();
        packet.ray.tnear[k] = 0.0f;
        packet.ray.tfar[k] = std::numeric_limits<float>::infinity();
        packet.ray.time[k] = 0.0f;
        packet.ray.mask[k] = std::numeric_limits<unsigned>::max();
        packet.ray.id[k] = static_cast<unsigned>(k);
        packet.ray.flags[k] = 0;
        packet.hit.geomID[k] = RTC_INVALID_GEOMETRY_ID;
      }
      rtcIntersect16(valid, scene_, &context, &packet);

      // write the tile's pixels
      for (int k = 0; k < kPacket; ++k) {
        if (valid[k] == 0) continue;
        const int i = tileX + k % kTile;
        const int j = tileY + k / kTile;
        const size_t pixel = static_cast<size_t>(j) * static_cast<size_t>(width) +
                             static_cast<size_t>(i);
        const bool hit = packet.hit.geomID[k] != RTC_INVALID_GEOMETRY_ID;
        const unsigned triangle = packet.hit.primID[k];
        if (outputs & kDepth) depth[pixel] = hit ? packet.ray.tfar[k] : 0.0f;
        if (outputs & kObject)
          objects[pixel] =
              (hit && !triangleObject.empty()) ? triangleObject[triangle] : -1;
        if (outputs & kColor) {
          uint8_t* out = rgb + 3 * pixel;
          if (hit) {
            shade(triangle, packet.hit.u[k], packet.hit.v[k], out);
          } else {
            out[0] = out[1] = out[2] = 0;
          }
        }
      }
    }
  }
}

void EmbreeRenderer::shade(unsigned triangle, float u, float v,
                           uint8_t* out) const {
  // colour = base colour x vertex colour x texture, all interpolated with the
  // hit's barycentrics (p = (1-u-v) p0 + u p1 + v p2, Embree's convention)
  const uint32_t* corner = mesh_.indices.data() + 3 * static_cast<size_t>(triangle);
  const float w = 1.0f - u - v;
  float color[3] = {1.0f, 1.0f, 1.0f};
  if (!mesh_.colors.empty()) {
    const Rgb8& c0 = mesh_.colors[corner[0]];
    const Rgb8& c1 = mesh_.colors[corner[1]];
    const Rgb8& c2 = mesh_.colors[corner[2]];
    for (int c = 0; c < 3; ++c)
      color[c] = (w * c0[c] + u * c1[c] + v * c2[c]) * (1.0f / 255.0f);
  }
  const int material =
      mesh_.triangle_material.empty() ? -1 : mesh_.triangle_material[triangle];
  const ShadeMaterial& m = materials_[static_cast<size_t>(material + 1)];
  color[0] *= m.r;
  color[1] *= m.g;
  color[2] *= m.b;
  if (m.texture != nullptr) {
    Vec2f uv = Vec2f::Zero();
    if (!mesh_.uvs.empty())
      uv = w * mesh_.uvs[corner[0]] + u * mesh_.uvs[corner[1]] +
           v * mesh_.uvs[corner[2]];
    float texel[3];
    sampleBilinear(*m.texture, uv.x(), uv.y(), texel);
    for (int c = 0; c < 3; ++c) color[c] *= texel[c];
  }
  for (int c = 0; c < 3; ++c) out[c] = toUnorm8(color[c]);
}

}  // namespace

std::unique_ptr<Renderer> createEmbreeRenderer(const TriangleMesh& mesh,
                                               const RayTracer& rayTracer) {
  return std::make_unique<EmbreeRenderer>(mesh, rayTracer);
}

}  // namespace vln::sim
