#include "waypoint/WaypointTargets.h"

#include <algorithm>
#include <cmath>

#include "common/Check.h"

namespace vln::waypoint {

namespace {

// A normalised 1-D Gaussian kernel truncated at 4 sigma (scipy's
// gaussian_filter default, which Hong et al. use).
std::vector<float> gaussianKernel(float sigma) {
  const int radius = static_cast<int>(std::ceil(4.0f * sigma));
  std::vector<float> kernel(static_cast<size_t>(2 * radius + 1));
  float sum = 0.0f;
  for (int i = -radius; i <= radius; ++i) {
    const float w =
        std::exp(-0.5f * static_cast<float>(i * i) / (sigma * sigma));
    kernel[static_cast<size_t>(i + radius)] = w;
    sum += w;
  }
  for (float& w : kernel) w /= sum;
  return kernel;
}

}  // namespace

std::array<float, kNumHeadings> openDistances(const sim::NavMesh& navmesh,
                                              const sim::AgentConfig& agent,
                                              const sim::AgentState& state) {
  std::array<float, kNumHeadings> open{};
  for (int h = 0; h < kNumHeadings; ++h) {
    sim::AgentState walker = state;
    walker.heading = wrapAngle(state.heading + binHeading(h));
    // walk until the first collision (where the agent stops counts, as the
    // collided step may still move it part of the way)
    for (int step = 0; step < kNumDistances; ++step) {
      const sim::StepResult result =
          sim::applyAction(navmesh, agent, walker, sim::Action::kMoveForward);
      if (result.collided) break;
    }
    const Vec3f moved = walker.position - state.position;
    open[static_cast<size_t>(h)] = std::hypot(moved.x(), moved.z());
  }
  return open;
}

bool isOpen(float openDistance, int d) {
  VLN_ASSERT(d >= 0 && d < kNumDistances);
  // whole steps reached; the tolerance absorbs float steps of 0.2499999 m
  return d < static_cast<int>(std::floor(openDistance / kDistanceStep + 1e-3f));
}

std::vector<float> targetHeatmap(const std::vector<TargetWaypoint>& targets,
                                 const std::array<float, kNumHeadings>& open,
                                 const WaypointTargetConfig& config) {
  std::vector<float> raw(kHeatmapSize, 0.0f);
  for (const TargetWaypoint& t : targets)
    raw[static_cast<size_t>(t.heading_bin * kNumDistances + t.distance_bin)] =
        1.0f;
  if (targets.empty()) return raw;

  // separable Gaussian: headings wrap around, distances see zeros beyond
  // both ends
  const std::vector<float> kh = gaussianKernel(config.sigma_heading);
  const std::vector<float> kd = gaussianKernel(config.sigma_distance);
  const int rh = static_cast<int>(kh.size() / 2);
  const int rd = static_cast<int>(kd.size() / 2);
  std::vector<float> across(kHeatmapSize, 0.0f);
  for (int h = 0; h < kNumHeadings; ++h)
    for (int d = 0; d < kNumDistances; ++d) {
      float sum = 0.0f;
      for (int i = -rd; i <= rd; ++i) {
        const int dd = d + i;
        if (dd < 0 || dd >= kNumDistances) continue;
        sum += kd[static_cast<size_t>(i + rd)] *
               raw[static_cast<size_t>(h * kNumDistances + dd)];
      }
      across[static_cast<size_t>(h * kNumDistances + d)] = sum;
    }
  std::vector<float> heatmap(kHeatmapSize, 0.0f);
  for (int h = 0; h < kNumHeadings; ++h)
    for (int d = 0; d < kNumDistances; ++d) {
      float sum = 0.0f;
      for (int i = -rh; i <= rh; ++i) {
        const int hh = ((h + i) % kNumHeadings + kNumHeadings) % kNumHeadings;
        sum += kh[static_cast<size_t>(i + rh)] *
               across[static_cast<size_t>(hh * kNumDistances + d)];
      }
      heatmap[static_cast<size_t>(h * kNumDistances + d)] = sum;
    }

  // peak 1 before masking, so that the kept share reads off the peak
  const float peak = *std::max_element(heatmap.begin(), heatmap.end());
  for (int h = 0; h < kNumHeadings; ++h)
    for (int d = 0; d < kNumDistances; ++d) {
      float& value = heatmap[static_cast<size_t>(h * kNumDistances + d)];
      value = isOpen(open[static_cast<size_t>(h)], d) ? value / peak : 0.0f;
    }
  return heatmap;
}

NodeTargets nodeTargets(
    const data::NavGraph& graph,
    const std::vector<data::NodeTransferResult>& transferred, int node,
    float heading, const sim::NavMesh& navmesh, const sim::AgentConfig& agent,
    const WaypointTargetConfig& config) {
  VLN_ASSERT(node >= 0 && node < graph.numNodes());
  VLN_ASSERT(transferred.size() == static_cast<size_t>(graph.numNodes()));
  VLN_CHECK_ARG(transferred[static_cast<size_t>(node)].valid,
                "nodeTargets(): node '", graph.node(node).id,
                "' was not transferred onto the navmesh");
  NodeTargets result;
  result.agent.position = transferred[static_cast<size_t>(node)].waypoint;
  result.agent.heading = wrapAngle(heading);

  // neighbours in range, the farther one per heading bin
  std::vector<int> byHeading(kNumHeadings, -1);
  for (int neighbour : graph.neighbors(node)) {
    const data::NodeTransferResult& t =
        transferred[static_cast<size_t>(neighbour)];
    if (!t.valid) continue;
    TargetWaypoint target;
    target.node = neighbour;
    target.position = t.waypoint;
    target.polar = toPolar(result.agent, t.waypoint);
    target.heading_bin = headingBin(target.polar.heading);
    target.distance_bin = distanceBin(target.polar.distance);
    if (target.distance_bin < 0) continue;
    int& slot = byHeading[static_cast<size_t>(target.heading_bin)];
    if (slot >= 0 && result.targets[static_cast<size_t>(slot)].polar.distance >=
                         target.polar.distance)
      continue;
    if (slot >= 0) {
      result.targets[static_cast<size_t>(slot)] = target;
    } else {
      slot = static_cast<int>(result.targets.size());
      result.targets.push_back(target);
    }
  }

  result.open = openDistances(navmesh, agent, result.agent);
  result.heatmap = targetHeatmap(result.targets, result.open, config);
  const float peak =
      *std::max_element(result.heatmap.begin(), result.heatmap.end());
  result.kept = !result.targets.empty() && peak >= config.min_peak_ratio;
  return result;
}

}  // namespace vln::waypoint
