#include "sim/Panorama.h"

#include <algorithm>
#include <cmath>
#include <span>

#include "common/Check.h"
#include "common/ThreadPool.h"
#include "sim/Renderer.h"
#include "sim/Scene.h"

namespace vln::sim {

void checkPanoramaConfig(const PanoramaConfig& config, std::string_view where) {
  // values set in code bypass the YAML reader's bounds checks
  PanoramaConfig copy = config;
  common::checkConfig([&](common::ConfigVisitor& v) { copy.visit(v); }, where);
  // a panorama sees all around: with gaps between views a waypoint could lie
  // in a direction no view shows
  for (const auto& [name, hfov] :
       {std::pair<const char*, float>{"rgb", config.rgb.hfov},
        std::pair<const char*, float>{"depth", config.depth.camera.hfov}}) {
    VLN_CHECK_ARG(static_cast<float>(config.num_views) * hfov >= 360.0f, where,
                  ": panorama.num_views (", config.num_views, ") x panorama.",
                  name, ".hfov (", hfov,
                  " degrees) must cover 360 degrees, the views leave gaps");
  }
  VLN_CHECK_ARG(config.depth.min_depth < config.depth.max_depth, where,
                ": panorama.depth.min_depth (", config.depth.min_depth,
                ") must be below panorama.depth.max_depth (",
                config.depth.max_depth, ")");
}

float panoramaViewHeading(float agentHeading, int view, int numViews) {
  VLN_ASSERT(numViews >= 1 && view >= 0 && view < numViews);
  return wrapAngle(agentHeading + 2.0f * kPi * static_cast<float>(view) /
                                      static_cast<float>(numViews));
}

PanoramaRenderer::PanoramaRenderer(const Scene& scene,
                                   const PanoramaConfig& config,
                                   RendererBackend backend)
    : config_(config) {
  checkPanoramaConfig(config_, "PanoramaRenderer: panorama config");
  // a renderer is not thread-safe: one per thread, all over the one scene
  // (Embree's share its BVH; creation is cheap)
  for (int t = 0; t < config_.threads; ++t)
    renderers_.push_back(
        createRenderer(scene.mesh(), scene.rayTracer(), backend));
  if (config_.threads > 1)
    pool_ = std::make_unique<common::ThreadPool>(config_.threads);
}

PanoramaRenderer::~PanoramaRenderer() = default;

void PanoramaRenderer::render(const AgentState& agent, Panorama& out) {
  const int views = config_.num_views;
  const CameraConfig& rgb = config_.rgb;
  const CameraConfig& depth = config_.depth.camera;
  // buffers keep their capacity from one panorama to the next
  out.num_views = views;
  out.heading = agent.heading;
  out.rgb_width = rgb.width;
  out.rgb_height = rgb.height;
  out.rgb.resize(static_cast<size_t>(views) * rgb.width * rgb.height * 3);
  out.depth_width = depth.width;
  out.depth_height = depth.height;
  out.depth.resize(static_cast<size_t>(views) * depth.width * depth.height);

  nextUnit_.store(0, std::memory_order_relaxed);
  if (!pool_) {
    renderViews(0, agent, out);
    return;
  }
  // one task per renderer, each taking the next view until none is left:
  // views differ in cost (a wall close by against a whole room), so a fixed
  // split would leave one thread waiting for the other
  pool_->parallelFor(renderers_.size(),
                     [&](size_t thread) { renderViews(thread, agent, out); });
}

void PanoramaRenderer::renderViews(size_t thread, const AgentState& agent,
                                   Panorama& out) {
  Renderer& renderer = *renderers_[thread];
  const int views = config_.num_views;
  const CameraConfig& rgb = config_.rgb;
  const CameraConfig& depth = config_.depth.camera;
  const size_t rgbSize = static_cast<size_t>(rgb.width) * rgb.height * 3;
  const size_t depthSize = static_cast<size_t>(depth.width) * depth.height;
  const bool shared = rgb == depth;
  // work units: whole views, except that the last views (one per renderer)
  // come as their colour and depth cameras apart, so that no renderer
  // waits long for another's last view (with one renderer: whole views)
  const int threads = static_cast<int>(renderers_.size());
  const int whole =
      (shared || threads == 1) ? views : std::max(0, views - threads);
  const int units = whole + 2 * (views - whole);
  for (int unit = nextUnit_.fetch_add(1, std::memory_order_relaxed);
       unit < units; unit = nextUnit_.fetch_add(1, std::memory_order_relaxed)) {
    const int view = unit < whole ? unit : whole + (unit - whole) / 2;
    const bool colour = unit < whole || (unit - whole) % 2 == 0;
    const bool depthToo = unit < whole || (unit - whole) % 2 == 1;
    // the camera poses of Simulator::observe() after turning to the view
    const float heading = panoramaViewHeading(agent.heading, view, views);
    const CameraPose rgbPose{agent.position + Vec3f(0.0f, rgb.position_y, 0.0f),
                             heading, agent.pitch};
    const CameraPose depthPose{
        agent.position + Vec3f(0.0f, depth.position_y, 0.0f), heading,
        agent.pitch};
    const std::span<uint8_t> rgbView(out.rgb.data() + view * rgbSize, rgbSize);
    const std::span<float> depthView(out.depth.data() + view * depthSize,
                                     depthSize);
    if (shared) {
      renderer.renderRgbDepth(rgbPose, {rgb.width, rgb.height, rgb.hfov},
                              rgbView, depthView);
      postprocessDepth(config_.depth, depthView);
      continue;
    }
    if (colour)
      renderer.renderRgb(rgbPose, {rgb.width, rgb.height, rgb.hfov}, rgbView);
    if (depthToo) {
      renderer.renderDepth(depthPose, {depth.width, depth.height, depth.hfov},
                           depthView);
      postprocessDepth(config_.depth, depthView);
    }
  }
}

}  // namespace vln::sim
