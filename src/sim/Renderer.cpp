#include "sim/Renderer.h"

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string_view>
#include <vector>

#include "common/Check.h"
#include "common/FileIo.h"
#include "sim/EmbreeRenderer.h"
#include "sim/GeometryCheck.h"
#include "sim/Mesh.h"
#include "sim/OsMesaRenderer.h"
#include "sim/RasterRenderer.h"
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
    case RendererBackend::kRaster:
      return createRasterRenderer(mesh);
  }
  VLN_ASSERT(false);
  return nullptr;
}

Renderer::Renderer(std::string_view backend, const TriangleMesh& mesh)
    : rgbMethod_(strCat(backend, "::renderRgb()")),
      depthMethod_(strCat(backend, "::renderDepth()")),
      rgbDepthMethod_(strCat(backend, "::renderRgbDepth()")),
      rgbDepthRgbMethod_(strCat(backend, "::renderRgbDepth() rgb")),
      rgbDepthDepthMethod_(strCat(backend, "::renderRgbDepth() depth")),
      semanticMethod_(strCat(backend, "::renderSemantic()")) {
  // the backends upload or trace this mesh; hostile geometry stops here
  mesh.validate(backend);
  checkSceneGeometry(mesh, backend);
  accepted_ = poseBounds(mesh.bounds());
}

void Renderer::checkEye(std::string_view method, const CameraPose& pose) const {
  // Embree (built with assertions in Debian) aborts on a ray from beyond
  // ~1.8e19; a camera far outside the scene sees nothing of it anyway
  checkPosition(method, "camera eye", pose.eye, accepted_);
}

void Renderer::renderRgb(const CameraPose& pose, const CameraIntrinsics& camera,
                         std::span<uint8_t> rgb) {
  checkRenderArgs(rgbMethod_, pose, camera, rgb.size(), 3);
  checkEye(rgbMethod_, pose);
  render(pose, camera, kColor, rgb.data(), nullptr, nullptr);
}

void Renderer::renderDepth(const CameraPose& pose,
                           const CameraIntrinsics& camera,
                           std::span<float> depth) {
  checkRenderArgs(depthMethod_, pose, camera, depth.size(), 1);
  checkEye(depthMethod_, pose);
  render(pose, camera, kDepth, nullptr, depth.data(), nullptr);
}

void Renderer::renderRgbDepth(const CameraPose& pose,
                              const CameraIntrinsics& camera,
                              std::span<uint8_t> rgb, std::span<float> depth) {
  checkRenderArgs(rgbDepthRgbMethod_, pose, camera, rgb.size(), 3);
  checkRenderArgs(rgbDepthDepthMethod_, pose, camera, depth.size(), 1);
  checkEye(rgbDepthMethod_, pose);
  render(pose, camera, kColor | kDepth, rgb.data(), depth.data(), nullptr);
}

void Renderer::renderSemantic(const CameraPose& pose,
                              const CameraIntrinsics& camera,
                              std::span<int32_t> objectIds) {
  checkRenderArgs(semanticMethod_, pose, camera, objectIds.size(), 1);
  checkEye(semanticMethod_, pose);
  render(pose, camera, kObject, nullptr, nullptr, objectIds.data());
}

RendererBackend parseRendererBackend(std::string_view name,
                                     std::string_view option) {
  if (name == "embree") return RendererBackend::kEmbree;
  if (name == "osmesa") return RendererBackend::kOsMesa;
  if (name == "raster") return RendererBackend::kRaster;
  throw std::invalid_argument(
      strCat(option, " must be embree, osmesa or raster, got '", name, "'"));
}

std::string_view rendererBackendName(RendererBackend backend) {
  switch (backend) {
    case RendererBackend::kEmbree:
      return "embree";
    case RendererBackend::kOsMesa:
      return "osmesa";
    case RendererBackend::kRaster:
      return "raster";
  }
  VLN_ASSERT(false);
  return "";
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

PixelSlopes pixelSlopes(const CameraIntrinsics& camera, int multiple) {
  VLN_ASSERT(multiple >= 1 && camera.width >= 1 && camera.height >= 1);
  auto padded = [&](int size) {
    return (size + multiple - 1) / multiple * multiple;
  };
  PixelSlopes slopes;
  slopes.columnX.resize(static_cast<size_t>(padded(camera.width)));
  slopes.rowY.resize(static_cast<size_t>(padded(camera.height)));
  for (size_t i = 0; i < slopes.columnX.size(); ++i)
    slopes.columnX[i] =
        pixelDirection(
            camera,
            static_cast<float>(std::min(static_cast<int>(i), camera.width - 1)),
            0.0f)
            .x();
  for (size_t j = 0; j < slopes.rowY.size(); ++j)
    slopes.rowY[j] =
        pixelDirection(camera, 0.0f,
                       static_cast<float>(
                           std::min(static_cast<int>(j), camera.height - 1)))
            .y();
  return slopes;
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

namespace {

void writePng(const std::filesystem::path& file, const cv::Mat& image,
              const char* method) {
  std::vector<uint8_t> png;
  VLN_CHECK_IO(cv::imencode(".png", image, png), method, ": ", file.string(),
               ": PNG encoding failed");
  common::writeFileAtomic(
      file, std::string_view(reinterpret_cast<const char*>(png.data()), png.size()));
}

}  // namespace

void saveRgbPng(const std::filesystem::path& file, int width, int height,
                std::span<const uint8_t> rgb) {
  checkRenderArgs("saveRgbPng()", CameraPose{}, CameraIntrinsics{width, height, 90.0f},
                  rgb.size(), 3);
  // OpenCV encodes BGR
  const cv::Mat view(height, width, CV_8UC3, const_cast<uint8_t*>(rgb.data()));
  cv::Mat bgr;
  cv::cvtColor(view, bgr, cv::COLOR_RGB2BGR);
  writePng(file, bgr, "saveRgbPng()");
}

void saveDepthPng(const std::filesystem::path& file, int width, int height,
                  std::span<const float> depth) {
  checkRenderArgs("saveDepthPng()", CameraPose{},
                  CameraIntrinsics{width, height, 90.0f}, depth.size(), 1);
  cv::Mat millimetres(height, width, CV_16UC1);
  for (int row = 0; row < height; ++row) {
    auto* out = millimetres.ptr<uint16_t>(row);
    for (int col = 0; col < width; ++col) {
      const float d = depth[static_cast<size_t>(row) * width + col];
      // NaN and negative values are not depths: written as "no hit"
      const float mm = (d > 0.0f) ? std::min(d * 1000.0f, 65535.0f) : 0.0f;
      out[col] = static_cast<uint16_t>(std::lround(mm));
    }
  }
  writePng(file, millimetres, "saveDepthPng()");
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
