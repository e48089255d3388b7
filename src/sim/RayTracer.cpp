#include "sim/RayTracer.h"

#include <embree3/rtcore.h>

#include <cmath>
#include <limits>
#include <mutex>
#include <string>

#include "common/App.h"
#include "common/Check.h"
#include "sim/GeometryCheck.h"

namespace vln::sim {

namespace {

// ---------------------------------------------------------------------------
// Embree handles and error reporting
// ---------------------------------------------------------------------------

struct DeviceDeleter {
  void operator()(RTCDeviceTy* device) const { rtcReleaseDevice(device); }
};
struct SceneDeleter {
  void operator()(RTCSceneTy* scene) const { rtcReleaseScene(scene); }
};
using DevicePtr = std::unique_ptr<RTCDeviceTy, DeviceDeleter>;
using ScenePtr = std::unique_ptr<RTCSceneTy, SceneDeleter>;

// Embree reports errors through a callback that may run on one of its build
// threads; the last message is kept so the exception thrown on the calling
// thread can say what went wrong.
struct ErrorLog {
  std::mutex mutex;
  std::string last;
};

ErrorLog& errorLog() {
  static ErrorLog log;
  return log;
}

void onEmbreeError(void* /*userPtr*/, RTCError code, const char* message) {
  ErrorLog& log = errorLog();
  std::lock_guard lock(log.mutex);
  log.last = strCat("Embree error ", static_cast<int>(code), ": ",
                    message ? message : "(no message)");
}

std::string lastEmbreeError() {
  ErrorLog& log = errorLog();
  std::lock_guard lock(log.mutex);
  return log.last.empty() ? std::string("unknown Embree error") : log.last;
}

// One device per process: creating a device starts Embree's task system, which
// is far too costly per scene. Each tracer retains it, so the static's
// destruction order at exit does not matter. Its kernels stop at AVX2 (as
// LibTorch's, common::pinNumericalRuntime): Embree's AVX-512 traversal
// rendered other depth bits than its AVX2 one, so identical configs trained
// different weights on machines with and without AVX-512.
RTCDevice sharedDevice() {
  static DevicePtr device = [] {
    RTCDevice created = rtcNewDevice(
        common::nativeCpuDispatch() ? "verbose=0" : "verbose=0,max_isa=avx2");
    VLN_CHECK_IO(created != nullptr,
                 "RayTracer: cannot create an Embree device (",
                 rtcGetDeviceError(nullptr) == RTC_ERROR_UNSUPPORTED_CPU
                     ? "unsupported CPU"
                     : "rtcNewDevice failed",
                 ")");
    rtcSetDeviceErrorFunction(created, onEmbreeError, nullptr);
    return DevicePtr(created);
  }();
  return device.get();
}

void throwIfDeviceError(RTCDevice device, const char* what) {
  const RTCError code = rtcGetDeviceError(device);
  VLN_CHECK_IO(code == RTC_ERROR_NONE, "RayTracer::RayTracer(): ", what,
               " failed: ", lastEmbreeError());
}

}  // namespace

// ---------------------------------------------------------------------------
// RayTracer
// ---------------------------------------------------------------------------

struct RayTracer::Impl {
  const TriangleMesh* mesh = nullptr;
  // the mesh's bounds grown by kPoseMargin: where rays may start
  Eigen::AlignedBox3f accepted;
  DevicePtr device;
  ScenePtr scene;
};

RayTracer::RayTracer(const TriangleMesh& mesh) : impl_(std::make_unique<Impl>()) {
  // Embree reads indices without bounds checks, so a malformed mesh must be
  // rejected before it reaches the BVH builder
  mesh.validate("RayTracer::RayTracer()");
  checkSceneGeometry(mesh, "RayTracer::RayTracer()");
  impl_->mesh = &mesh;
  impl_->accepted = poseBounds(mesh.bounds());

  RTCDevice device = sharedDevice();
  rtcRetainDevice(device);
  impl_->device.reset(device);

  // a single static triangle geometry; Embree-owned buffers are padded so
  // its SIMD loads of the last vertex stay in bounds
  RTCGeometry geometry = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
  throwIfDeviceError(device, "rtcNewGeometry");
  auto* vertices = static_cast<float*>(rtcSetNewGeometryBuffer(
      geometry, RTC_BUFFER_TYPE_VERTEX, /*slot=*/0, RTC_FORMAT_FLOAT3,
      3 * sizeof(float), mesh.positions.size()));
  auto* triangles = static_cast<uint32_t*>(rtcSetNewGeometryBuffer(
      geometry, RTC_BUFFER_TYPE_INDEX, /*slot=*/0, RTC_FORMAT_UINT3,
      3 * sizeof(uint32_t), mesh.triangleCount()));
  if (vertices == nullptr || triangles == nullptr) {
    rtcReleaseGeometry(geometry);
    throwIfDeviceError(device, "rtcSetNewGeometryBuffer");
    VLN_CHECK_IO(false, "RayTracer::RayTracer(): cannot allocate buffers for ",
                 mesh.triangleCount(), " triangles");
  }
  for (size_t i = 0; i < mesh.positions.size(); ++i) {
    vertices[3 * i + 0] = mesh.positions[i].x();
    vertices[3 * i + 1] = mesh.positions[i].y();
    vertices[3 * i + 2] = mesh.positions[i].z();
  }
  std::copy(mesh.indices.begin(), mesh.indices.end(), triangles);
  rtcCommitGeometry(geometry);

  // a high-quality (SAH with spatial splits) BVH: scenes are built once and
  // traced millions of times. ROBUST keeps shared edges watertight, so the
  // renderers show no cracks between adjacent triangles.
  impl_->scene.reset(rtcNewScene(device));
  rtcSetSceneBuildQuality(impl_->scene.get(), RTC_BUILD_QUALITY_HIGH);
  rtcSetSceneFlags(impl_->scene.get(), RTC_SCENE_FLAG_ROBUST);
  rtcAttachGeometry(impl_->scene.get(), geometry);
  rtcReleaseGeometry(geometry);
  rtcCommitScene(impl_->scene.get());
  throwIfDeviceError(device, "building the BVH");
}

RayTracer::~RayTracer() = default;

std::optional<RayHit> RayTracer::cast(const Vec3f& origin,
                                      const Vec3f& direction,
                                      float maxDistance) const {
  const float length = direction.norm();
  VLN_CHECK_ARG(std::isfinite(length) && length > 0.0f,
                "RayTracer::cast(): direction must be finite and non-zero, "
                "got (",
                direction.transpose(), ")");
  // Debian's Embree asserts on invalid rays (an origin beyond ~1.8e19, a
  // NaN tfar) and aborts
  checkPosition("RayTracer::cast()", "origin", origin, impl_->accepted);
  VLN_CHECK_ARG(maxDistance >= 0.0f,
                "RayTracer::cast(): maxDistance must be >= 0, got ",
                maxDistance);
  const Vec3f dir = direction / length;

  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  RTCRayHit rayHit{};
  rayHit.ray.org_x = origin.x();
  rayHit.ray.org_y = origin.y();
  rayHit.ray.org_z = origin.z();
  rayHit.ray.dir_x = dir.x();
  rayHit.ray.dir_y = dir.y();
  rayHit.ray.dir_z = dir.z();
  rayHit.ray.tnear = 0.0f;
  rayHit.ray.tfar = maxDistance;
  rayHit.ray.mask = std::numeric_limits<unsigned>::max();
  rayHit.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rtcIntersect1(impl_->scene.get(), &context, &rayHit);
  if (rayHit.hit.geomID == RTC_INVALID_GEOMETRY_ID) return std::nullopt;

  RayHit hit;
  hit.distance = rayHit.ray.tfar;
  hit.point = origin + dir * hit.distance;
  hit.normal = Vec3f(rayHit.hit.Ng_x, rayHit.hit.Ng_y, rayHit.hit.Ng_z);
  const float normalLength = hit.normal.norm();
  if (normalLength > 0.0f) hit.normal /= normalLength;
  // Embree's Ng follows the winding; callers want the side the ray came from
  if (hit.normal.dot(dir) > 0.0f) hit.normal = -hit.normal;
  hit.triangle = static_cast<int>(rayHit.hit.primID);
  const auto& objects = impl_->mesh->triangle_object;
  hit.object = objects.empty() ? -1 : objects[rayHit.hit.primID];
  return hit;
}

bool RayTracer::visible(const Vec3f& a, const Vec3f& b) const {
  checkPosition("RayTracer::visible()", "a", a, impl_->accepted);
  checkPosition("RayTracer::visible()", "b", b, impl_->accepted);
  const Vec3f delta = b - a;
  const float length = delta.norm();
  // the endpoints usually lie on surfaces (floor, navmesh); 0.1 mm of slack
  // at both ends keeps those surfaces from occluding their own points
  constexpr float kEndSlack = 1e-4f;
  if (length <= 2.0f * kEndSlack) return true;
  const Vec3f dir = delta / length;

  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  RTCRay ray{};
  ray.org_x = a.x();
  ray.org_y = a.y();
  ray.org_z = a.z();
  ray.dir_x = dir.x();
  ray.dir_y = dir.y();
  ray.dir_z = dir.z();
  ray.tnear = kEndSlack;
  ray.tfar = length - kEndSlack;
  ray.mask = std::numeric_limits<unsigned>::max();
  rtcOccluded1(impl_->scene.get(), &context, &ray);
  // Embree marks an occluded ray by setting tfar to -inf
  return ray.tfar >= 0.0f;
}

const TriangleMesh& RayTracer::mesh() const { return *impl_->mesh; }

void* RayTracer::embreeScene() const { return impl_->scene.get(); }

}  // namespace vln::sim
