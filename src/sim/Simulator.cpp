#include "sim/Simulator.h"

#include <cmath>
#include <limits>
#include <utility>

#include "common/Check.h"
#include "common/Config.h"
#include "sim/GeometryCheck.h"

namespace vln::sim {

namespace {

// A start further than this from the navmesh is not "on" it: R2R_VLNCE start
// points lie on the navmesh, so a larger gap means a wrong scene or a
// corrupt episode rather than rounding.
constexpr float kMaxSnapDistance = 0.5f;

CameraIntrinsics intrinsics(const CameraConfig& camera) {
  return {camera.width, camera.height, camera.hfov};
}

// The sensor sits position_y above the agent's feet and looks along its
// heading, tilted by the agent's pitch (level unless look actions moved it);
// the pitch turns the camera about its own centre, as Habitat's sensors
// turn about their node, so the eye does not move.
CameraPose cameraPose(const AgentState& agent, const CameraConfig& camera) {
  CameraPose pose;
  pose.eye = agent.position + Vec3f(0.0f, camera.position_y, 0.0f);
  pose.heading = agent.heading;
  pose.pitch = agent.pitch;
  return pose;
}

}  // namespace

Simulator::Simulator(std::shared_ptr<const Scene> scene, const SimConfig& sim,
                     const TaskConfig& task)
    : sim_(sim), task_(task) {
  // values set in code bypass the YAML reader's bounds checks
  common::checkConfig([&](common::ConfigVisitor& v) { sim_.visit(v); },
                      "Simulator: sim config");
  common::checkConfig([&](common::ConfigVisitor& v) { task_.visit(v); },
                      "Simulator: task config");
  VLN_CHECK_ARG(sim_.depth.min_depth < sim_.depth.max_depth,
                "Simulator: sim.depth.min_depth (", sim_.depth.min_depth,
                ") must be below sim.depth.max_depth (", sim_.depth.max_depth,
                ")");
  setScene(std::move(scene));
}

Simulator::~Simulator() = default;

void Simulator::setScene(std::shared_ptr<const Scene> scene) {
  VLN_CHECK_ARG(scene != nullptr, "Simulator::setScene(): scene is null");
  // the renderer holds references into the scene, so it goes first
  renderer_.reset();
  panorama_.reset();
  scene_ = std::move(scene);
  renderer_ =
      createRenderer(scene_->mesh(), scene_->rayTracer(), sim_.renderer);
  episode_ = EpisodeState{};
  hasEpisode_ = false;
}

void Simulator::reset(const AgentState& start) {
  VLN_CHECK_ARG(start.position.allFinite() && std::isfinite(start.heading) &&
                    std::isfinite(start.pitch),
                "Simulator::reset(): scene '", scene_->name(),
                "': start must be finite, got position (",
                start.position.transpose(), "), heading ", start.heading,
                ", pitch ", start.pitch);
  checkPosition(strCat("Simulator::reset(): scene '", scene_->name(), "'"),
                "start position", start.position,
                scene_->navmesh().queryBounds());
  const auto snapped = scene_->navmesh().snapPoint(start.position);
  const float gap = snapped ? (*snapped - start.position).norm()
                            : std::numeric_limits<float>::infinity();
  VLN_CHECK_ARG(
      snapped && gap <= kMaxSnapDistance, "Simulator::reset(): scene '",
      scene_->name(), "': start position (", start.position.transpose(),
      ") is not within ", kMaxSnapDistance,
      " m of navigable space (nearest navmesh point ",
      snapped ? strCat("at ", gap, " m") : std::string("not found"), ")");
  episode_ = EpisodeState{};
  episode_.agent.position = *snapped;
  episode_.agent.heading = start.heading;
  episode_.agent.pitch = wrapAngle(start.pitch);
  hasEpisode_ = true;
}

StepResult Simulator::step(Action action) {
  VLN_ASSERT(hasEpisode_);
  return stepEpisode(scene_->navmesh(), sim_.agent, task_, episode_, action);
}

StepResult Simulator::teleport(const AgentState& target) {
  VLN_ASSERT(hasEpisode_);
  return teleportEpisode(scene_->navmesh(), task_, episode_, target);
}

void Simulator::observe(Observation& out) {
  VLN_ASSERT(hasEpisode_);
  const CameraConfig& rgbCamera = sim_.rgb;
  const CameraConfig& depthCamera = sim_.depth.camera;
  out.rgb_width = rgbCamera.width;
  out.rgb_height = rgbCamera.height;
  out.rgb.resize(static_cast<size_t>(rgbCamera.width) * rgbCamera.height * 3);
  out.depth_width = depthCamera.width;
  out.depth_height = depthCamera.height;
  out.depth.resize(static_cast<size_t>(depthCamera.width) * depthCamera.height);

  // one pass when both sensors are the same camera (VLN-CE's default)
  if (rgbCamera == depthCamera) {
    renderer_->renderRgbDepth(cameraPose(episode_.agent, rgbCamera),
                              intrinsics(rgbCamera), out.rgb, out.depth);
  } else {
    renderer_->renderRgb(cameraPose(episode_.agent, rgbCamera),
                         intrinsics(rgbCamera), out.rgb);
    renderer_->renderDepth(cameraPose(episode_.agent, depthCamera),
                           intrinsics(depthCamera), out.depth);
  }
  postprocessDepth(sim_.depth, out.depth);
}

void Simulator::observePanorama(const PanoramaConfig& config,
                                Panorama& out) {
  VLN_ASSERT(hasEpisode_);
  // only waypoint agents look around: the others never pay for the renderers
  if (!panorama_ || !(panorama_->config() == config))
    panorama_ = std::make_unique<PanoramaRenderer>(*scene_, config,
                                                   sim_.renderer);
  panorama_->render(episode_.agent, out);
}

void Simulator::observeSemantic(std::vector<int32_t>& objectIds) {
  VLN_ASSERT(hasEpisode_);
  const CameraConfig& camera = sim_.rgb;
  objectIds.resize(static_cast<size_t>(camera.width) * camera.height);
  renderer_->renderSemantic(cameraPose(episode_.agent, camera),
                            intrinsics(camera), objectIds);
}

}  // namespace vln::sim
