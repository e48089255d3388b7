#include "viz/ObservationImages.h"

#include <algorithm>
#include <cmath>

namespace vln::viz {

float depthDisplayScale(const sim::Simulator& simulator) {
  const auto& depth = simulator.config().depth;
  return depth.normalize_depth ? 1.0f : depth.max_depth;
}

std::vector<uint8_t> depthGreyLevels(const sim::Observation& observation,
                                     float scale) {
  std::vector<uint8_t> grey(observation.depth.size());
  for (size_t i = 0; i < grey.size(); ++i)
    grey[i] = static_cast<uint8_t>(std::lround(
        255.0f * std::clamp(observation.depth[i] / scale, 0.0f, 1.0f)));
  return grey;
}

float distanceToGoal(const sim::Simulator& simulator,
                     const data::Episode& episode, const Vec3f& position) {
  if (episode.goals.empty()) return -1.0f;
  return simulator.scene().navmesh().geodesicDistance(
      position, episode.goals.front().position);
}

}  // namespace vln::viz
