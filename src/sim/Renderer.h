#pragma once
// Egocentric RGB-D rendering into caller-owned buffers. Three backends share
// this interface and produce matching images: an Embree ray caster
// (coherent packets), an OSMesa rasteriser and the project's own CPU
// rasteriser. Materials are unlit: colour = base colour x vertex colour x
// texture, so all agree exactly on shading.

#include <cstdint>
#include <filesystem>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "common/Math.h"
#include "sim/SimConfig.h"

namespace vln::sim {

class RayTracer;
struct TriangleMesh;

/// A pinhole camera pose: eye position (world) and heading (radians, as
/// AgentState) plus pitch (radians, positive looks up).
struct CameraPose {
  Vec3f eye = Vec3f::Zero();
  float heading = 0.0f;
  float pitch = 0.0f;
};

/// Image size and field of view of one render.
struct CameraIntrinsics {
  int width = 256;
  int height = 256;
  float hfov_deg = 90.0f;
};

/// Renders one scene. Not thread-safe: one thread at a time uses a renderer
/// (it may move between threads), so give each thread its own (creation is
/// cheap for Embree; OSMesa uploads the mesh once per renderer, and OSMesa
/// renders of one process run one at a time, see OsMesaRenderer.h).
///
/// The public methods check the camera, the buffer sizes and that the eye
/// lies within the scene's bounds grown by kPoseMargin (GeometryCheck.h),
/// throwing std::invalid_argument naming "<Backend>::<method>()", and hand
/// one pass to the backend's render().
class Renderer {
 public:
  virtual ~Renderer() = default;

  /// Colour image [height, width, 3] uint8, row-major, top row first.
  /// `rgb.size()` must be width*height*3.
  void renderRgb(const CameraPose& pose, const CameraIntrinsics& camera,
                 std::span<uint8_t> rgb);
  /// Depth image [height, width] float32: distance along the optical axis
  /// (z-depth, as Habitat), metres; 0 where no surface is hit.
  void renderDepth(const CameraPose& pose, const CameraIntrinsics& camera,
                   std::span<float> depth);
  /// Colour and depth of the same camera in one pass.
  void renderRgbDepth(const CameraPose& pose, const CameraIntrinsics& camera,
                      std::span<uint8_t> rgb, std::span<float> depth);
  /// Semantic object id per pixel [height, width] int32, -1 where the
  /// surface has none or nothing is hit.
  void renderSemantic(const CameraPose& pose, const CameraIntrinsics& camera,
                      std::span<int32_t> objectIds);

  /// The images one render() pass writes, as a bit set.
  enum Output : unsigned { kColor = 1u, kDepth = 2u, kObject = 4u };

 protected:
  /// `backend` names the backend in error messages ("EmbreeRenderer");
  /// `mesh` is the scene it renders. Throws std::invalid_argument when the
  /// mesh fails checkSceneGeometry() (GeometryCheck.h).
  Renderer(std::string_view backend, const TriangleMesh& mesh);

  /// One pass of the backend: writes the images named by `outputs` (Output
  /// bits) into `rgb` [height, width, 3], `depth` [height, width] and
  /// `objects` [height, width], in the layouts of the public methods. The
  /// buffers of the requested outputs have been checked against `camera`;
  /// the others are null.
  virtual void render(const CameraPose& pose, const CameraIntrinsics& camera,
                      unsigned outputs, uint8_t* rgb, float* depth,
                      int32_t* objects) = 0;

 private:
  // throws naming `method` unless the eye is finite and near the scene
  void checkEye(std::string_view method, const CameraPose& pose) const;

  // "<backend>::<method>()", built once rather than per render
  std::string rgbMethod_;
  std::string depthMethod_;
  std::string rgbDepthMethod_;
  std::string rgbDepthRgbMethod_;
  std::string rgbDepthDepthMethod_;
  std::string semanticMethod_;
  // the scene's bounds grown by kPoseMargin
  Eigen::AlignedBox3f accepted_;
};

/// A renderer of `mesh` using `backend`; the Embree backend traces against
/// `rayTracer` (built from the same mesh). Both must outlive the renderer.
/// Throws std::runtime_error when the backend cannot start (e.g. no OSMesa).
std::unique_ptr<Renderer> createRenderer(const TriangleMesh& mesh,
                                         const RayTracer& rayTracer,
                                         RendererBackend backend);

/// The backend called `name`: "embree", "osmesa" or "raster" (as in
/// SimConfig's `renderer`). Throws std::invalid_argument naming `option` (e.g.
/// the command-line flag) and `name` otherwise.
RendererBackend parseRendererBackend(std::string_view name,
                                     std::string_view option);

/// The name parseRendererBackend() reads as `backend`.
std::string_view rendererBackendName(RendererBackend backend);

/// Rotation from the camera frame to the world frame for `pose`. The camera
/// frame is OpenGL's: +X right, +Y up, looking along -Z; pitch is applied
/// before heading, R = Ry(heading) * Rx(pitch), so heading 0 and pitch 0 look
/// along world -Z as an agent does (common/Math.h).
Eigen::Matrix3f cameraToWorld(const CameraPose& pose);

/// Tangent of half the vertical field of view. Pixels are square, as in
/// Habitat: tan(vfov/2) = tan(hfov/2) * height / width.
float tanHalfVerticalFov(const CameraIntrinsics& camera);

/// Camera-frame direction (z = -1, unnormalised) through the centre of pixel
/// (column, row), row 0 at the top: pixel centres sit at (i + 0.5), so both
/// backends sample the same points. Its distance along the optical axis is 1,
/// hence a hit at ray parameter t has z-depth t.
Vec3f pixelDirection(const CameraIntrinsics& camera, float column, float row);

/// Camera-frame ray slopes of `camera`'s pixel centres (pixelDirection()):
/// X per column and Y per row, each padded to a multiple of `multiple`
/// entries that repeat the last pixel's, so that lanes past the image's edge
/// still carry finite rays.
struct PixelSlopes {
  std::vector<float> columnX;
  std::vector<float> rowY;
};
PixelSlopes pixelSlopes(const CameraIntrinsics& camera, int multiple);

/// Throws std::invalid_argument naming `method` when the intrinsics are out
/// of range (size < 1, hfov outside (0, 180) degrees), the pose is not
/// finite, or `bufferSize` differs from width * height * `channels`.
void checkRenderArgs(std::string_view method, const CameraPose& pose,
                     const CameraIntrinsics& camera, size_t bufferSize,
                     int channels);

/// Writes an RGB image [height, width, 3] uint8 as an 8-bit PNG, atomically.
/// Throws std::invalid_argument when the size does not match and
/// std::runtime_error naming the file when it cannot be written.
void saveRgbPng(const std::filesystem::path& file, int width, int height,
                std::span<const uint8_t> rgb);

/// Writes a raw depth image [height, width] float32 (metres, 0 = no hit) as
/// a 16-bit greyscale PNG in millimetres: round(depth * 1000), so 0 stays
/// "no hit" and depths beyond 65.535 m saturate at 65535. Atomic; throws as
/// saveRgbPng().
void saveDepthPng(const std::filesystem::path& file, int width, int height,
                  std::span<const float> depth);

/// Clips raw depth (metres, 0 = miss) to [min_depth, max_depth] (misses
/// become max_depth) and, if normalize_depth, maps it to [0, 1], in place.
void postprocessDepth(const DepthCameraConfig& config, std::span<float> depth);

}  // namespace vln::sim
