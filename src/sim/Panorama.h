#pragma once
// Panoramic RGB-D observation: N views at the agent's position, turned
// 360/N degrees apart, as the waypoint agents of Hong et al. (CVPR 2022,
// "Bridging the Gap Between Learning in Discrete and Continuous
// Environments for VLN") and VLN-CE's WPN/HPN see the world. Every view is
// exactly the single-view observation (Simulator::observe()) the agent would
// get after turning to that heading: same renderer, same camera model, same
// depth post-processing.
//
// Heading convention (docs/waypoints.md): view 0 looks along the agent's
// heading; view k looks at heading + k * 2*pi/N, i.e. the views go
// counter-clockwise seen from above (+Y up), turning LEFT, the sign of
// AgentState::heading. With N = 12 view 3 looks left (90 degrees), view 9
// right. This is the order in which Hong et al. render their cameras
// (habitat orientations [0, k*pi/6, 0]); they reverse it to clockwise only
// inside their predictor.

#include <atomic>
#include <cstdint>
#include <memory>
#include <string_view>
#include <vector>

#include "common/Config.h"
#include "common/Math.h"
#include "sim/Agent.h"
#include "sim/SimConfig.h"

namespace vln::common {
class ThreadPool;
}

namespace vln::sim {

class Renderer;
class Scene;

/// The panorama's views. Defaults are Hong et al.'s: 12 views 30 degrees
/// apart, RGB 224x224 and depth 256x256 (the input sizes of the ImageNet
/// ResNet-50 and the DD-PPO depth ResNet), both with a 90 degree HFOV, so
/// neighbouring views overlap by 60 degrees and every direction is seen by
/// three views (their habitat_extensions/config/vlnce_task.yaml).
///
/// Deliberately not a section of SimConfig: the low-level agents' runs hash
/// the sim section into their feature stores (train/Collector.cpp), and a
/// panorama changes nothing they record. A waypoint run's config holds it
/// as its own section (`panorama:`).
struct PanoramaConfig {
  int num_views = 12;
  CameraConfig rgb{224, 224, 90.0f, 1.25f};
  DepthCameraConfig depth;
  /// Views rendered in parallel, one renderer per thread. 1 renders on the
  /// calling thread (what parallel environments want); 2 splits the views
  /// across both cores of a small machine.
  int threads = 1;

  void visit(common::ConfigVisitor& v) {
    v.field("num_views", num_views,
            "Views of a panorama, 360/num_views degrees apart, view 0 "
            "along the agent's heading, counter-clockwise",
            common::inRange(1, 360));
    v.section("rgb", rgb, "RGB camera of each view");
    v.section("depth", depth, "Depth camera of each view");
    v.field("threads", threads,
            "Threads rendering one panorama's views (one renderer each)",
            common::inRange(1, 64));
  }
  bool operator==(const PanoramaConfig&) const = default;
};

/// Throws std::invalid_argument naming `where` and the field when `config`
/// is out of range (the visit() bounds), the views leave gaps
/// (num_views * hfov < 360 for either camera) or depth.min_depth is not
/// below depth.max_depth.
void checkPanoramaConfig(const PanoramaConfig& config, std::string_view where);

/// Heading (radians, AgentState convention, wrapped to (-pi, pi]) of view
/// `view` of `numViews` for an agent at `agentHeading`:
/// agentHeading + view * 2*pi/numViews.
float panoramaViewHeading(float agentHeading, int view, int numViews);

/// One panorama: views stacked view-major.
struct Panorama {
  int num_views = 0;
  int rgb_width = 0;
  int rgb_height = 0;
  std::vector<uint8_t> rgb;  ///< [num_views, rgb_height, rgb_width, 3]
  int depth_width = 0;
  int depth_height = 0;
  /// [num_views, depth_height, depth_width], post-processed per
  /// PanoramaConfig::depth (clipped, normalised to [0, 1] by default).
  std::vector<float> depth;
  /// The agent's heading when rendered (radians); view k looks at
  /// panoramaViewHeading(heading, k, num_views).
  float heading = 0.0f;
};

/// Renders panoramas of one scene. Holds `config.threads` renderers of the
/// backend and a thread pool; not thread-safe itself (one per environment,
/// like Simulator). The scene must outlive it.
class PanoramaRenderer {
 public:
  /// Throws what checkPanoramaConfig() and createRenderer() throw.
  PanoramaRenderer(const Scene& scene, const PanoramaConfig& config,
                   RendererBackend backend);
  ~PanoramaRenderer();
  PanoramaRenderer(const PanoramaRenderer&) = delete;
  PanoramaRenderer& operator=(const PanoramaRenderer&) = delete;

  /// Renders the panorama of an agent standing at `agent` (feet position,
  /// heading, camera pitch) into `out`, resizing its buffers only when the
  /// sizes change. Cameras sit position_y above the feet. Throws
  /// std::invalid_argument (from the renderer) when the eye is far outside
  /// the scene.
  void render(const AgentState& agent, Panorama& out);

  const PanoramaConfig& config() const { return config_; }

 private:
  // renders the work left (taking units one by one from nextUnit_: whole
  // views, the last ones as separate colour and depth cameras) with
  // renderer `thread`
  void renderViews(size_t thread, const AgentState& agent, Panorama& out);

  PanoramaConfig config_;
  std::vector<std::unique_ptr<Renderer>> renderers_;
  std::unique_ptr<common::ThreadPool> pool_;  // null with one thread
  std::atomic<int> nextUnit_{0};
};

}  // namespace vln::sim
