#include "sim/Renderer.h"

#include <algorithm>
#include <cmath>

#include "common/Check.h"
#include "sim/EmbreeRenderer.h"
#include "sim/OsMesaRenderer.h"
#include "sim/RayTracer.h"

namespace vln::sim {

std::unique_ptr<Renderer> createRenderer(const TriangleMesh& mesh,
                                         const RayTracer& rayTracer,
                                         RendererBackend backend) {
  // the Embree backend reads materials from `mesh` and hits from the BVH;
  // they must describe the same triangles
  VLN_ASSERT(&rayTracer.mesh() == &mesh);
  switch (backend) {
    case RendererBackend::kEmbree:
      return createEmbreeRenderer(mesh, rayTracer);
    case RendererBackend::kOsMesa:
      return createOsMesaRenderer(mesh);
  }
  VLN_ASSERT(false);
  return nullptr;
}

Eigen::Matrix3f cameraToWorld(const CameraPose& pose) {
  return (Eigen::AngleAxisf(pose.heading, Vec3f::UnitY()) *
          Eigen::AngleAxisf(pose.pitch, Vec3f::UnitX()))
      .toRotationMatrix();
}

float tanHalfVerticalFov(const CameraIntrinsics& camera) {
  return std::tan(degToRad(camera.hfov_deg) / 2.0f) *
         static_cast<float>(camera.height) / static_cast<float>(camera.width);
}

Vec3f pixelDirection(const CameraIntrinsics& camera, float column, float row) {
  const float tanX = std::tan(degToRad(camera.hfov_deg) / 2.0f);
  const float tanY = tanHalfVerticalFov(camera);
  const float x = (2.0f * (column + 0.5f) / static_cast<float>(camera.width) -
                   1.0f) * tanX;
  const float y = (1.0f - 2.0f * (row + 0.5f) /
                              static_cast<float>(camera.height)) * tanY;
  return {x, y, -1.0f};
}

void checkRenderArgs(std::string_view method, const CameraPose& pose,
                     const CameraIntrinsics& camera, size_t bufferSize,
                     int channels) {
  VLN_CHECK_ARG(camera.width >= 1 && camera.height >= 1, method,
                ": image size must be at least 1x1, got ", camera.width, "x",
                camera.height);
  VLN_CHECK_ARG(camera.hfov_deg > 0.0f && camera.hfov_deg < 180.0f, method,
                ": hfov_deg must be in (0, 180), got ", camera.hfov_deg);
  VLN_CHECK_ARG(pose.eye.allFinite() && std::isfinite(pose.heading) &&
                    std::isfinite(pose.pitch),
                method, ": camera pose must be finite, got eye (",
                pose.eye.transpose(), "), heading ", pose.heading, ", pitch ",
                pose.pitch);
  const size_t expected = static_cast<size_t>(camera.width) *
                          static_cast<size_t>(camera.height) *
                          static_cast<size_t>(channels);
  VLN_CHECK_ARG(bufferSize == expected, method, ": buffer holds ", bufferSize,
                " elements, expected ", expected, " for ", camera.width, "x",
                camera.height, "x", channels);
}

void postprocessDepth(const DepthCameraConfig& config, std::span<float> depth) {
  const float lo = config.min_depth;
  const float hi = config.max_depth;
  VLN_CHECK_ARG(lo < hi,
                "postprocessDepth(): min_depth must be below max_depth, got "
                "min_depth ",
                lo, ", max_depth ", hi);
  const float scale = config.normalize_depth ? 1.0f / (hi - lo) : 1.0f;
  const float offset = config.normalize_depth ? lo : 0.0f;
  for (float& d : depth) {
    // a miss (0, or NaN from a degenerate hit) means "nothing within range"
    const float clipped = (d > 0.0f) ? std::clamp(d, lo, hi) : hi;
    d = (clipped - offset) * scale;
  }
}

}  // namespace vln::sim
