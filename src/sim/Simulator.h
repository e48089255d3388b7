#pragma once
// One environment: a shared Scene, a per-thread renderer and one episode's
// state. Create one Simulator per thread.

#include <cstdint>
#include <memory>
#include <vector>

#include "sim/Agent.h"
#include "sim/Panorama.h"
#include "sim/Renderer.h"
#include "sim/Scene.h"
#include "sim/SimConfig.h"

namespace vln::sim {

/// Egocentric observation buffers.
struct Observation {
  int rgb_width = 0;
  int rgb_height = 0;
  std::vector<uint8_t> rgb;  ///< [rgb_height, rgb_width, 3]
  int depth_width = 0;
  int depth_height = 0;
  std::vector<float> depth;  ///< [depth_height, depth_width], post-processed
                             ///< per DepthCameraConfig
};

class Simulator {
 public:
  Simulator(std::shared_ptr<const Scene> scene, const SimConfig& sim,
            const TaskConfig& task);
  ~Simulator();

  /// Starts an episode at `start`; the position is snapped to the navmesh,
  /// heading and pitch are kept (dataset episodes start level, pitch 0, as
  /// Habitat resets its sensors; a restored state keeps its pitch).
  /// Throws std::invalid_argument when `start` is not finite, outside the
  /// navmesh's queryBounds() or not near navigable space.
  void reset(const AgentState& start);
  /// Takes one action (see stepEpisode()). Calling it before reset() or
  /// after the episode is done is a bug (aborts).
  StepResult step(Action action);
  /// Takes one teleport step towards `target` (teleportEpisode(): snapped
  /// to the navmesh on the agent's island or refused, counted as a step).
  /// Same preconditions as step().
  StepResult teleport(const AgentState& target);
  /// Renders RGB and depth at the current pose (the agent's heading and the
  /// cameras' pitch) into `out` (resized as needed). RGB and depth share one
  /// pass when their cameras are equal.
  void observe(Observation& out);
  /// Renders the panorama `config` describes at the current pose: view k is
  /// what observe() would render after turning to
  /// panoramaViewHeading(heading, k, num_views), with the panorama's
  /// cameras (sim/Panorama.h), on this simulator's backend. The panorama
  /// renderer is created on the first call and again when `config`
  /// changes. Throws what checkPanoramaConfig() throws.
  void observePanorama(const PanoramaConfig& config, Panorama& out);
  /// Renders the semantic object ids seen by the RGB camera.
  void observeSemantic(std::vector<int32_t>& objectIds);

  const EpisodeState& episode() const { return episode_; }
  const Scene& scene() const { return *scene_; }
  const std::shared_ptr<const Scene>& scenePtr() const { return scene_; }
  /// Replaces the scene (e.g. the next episode is in another house); the
  /// next episode must start with reset().
  void setScene(std::shared_ptr<const Scene> scene);
  const SimConfig& config() const { return sim_; }
  const TaskConfig& task() const { return task_; }

 private:
  std::shared_ptr<const Scene> scene_;
  SimConfig sim_;
  TaskConfig task_;
  std::unique_ptr<Renderer> renderer_;
  std::unique_ptr<PanoramaRenderer> panorama_;  ///< made by observePanorama()
  EpisodeState episode_;
  bool hasEpisode_ = false;  ///< reset() has placed the agent in scene_
};

}  // namespace vln::sim
