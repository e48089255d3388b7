#include "waypoint/DepthWaypointBaseline.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include "common/Check.h"
#include "sim/Renderer.h"

namespace vln::waypoint {

DepthBaselineResult depthBaselineCandidates(const sim::Panorama& pano,
                                            const sim::PanoramaConfig& panorama,
                                            const DepthBaselineConfig& config) {
  DepthBaselineConfig checked = config;
  common::checkConfig([&](common::ConfigVisitor& v) { checked.visit(v); },
                      "depthBaselineCandidates(): baseline config");
  const sim::DepthCameraConfig& depth = panorama.depth;
  const int width = depth.camera.width;
  const int height = depth.camera.height;
  VLN_CHECK_ARG(pano.num_views == panorama.num_views &&
                    pano.depth_width == width && pano.depth_height == height &&
                    pano.depth.size() ==
                        static_cast<size_t>(pano.num_views) * width * height,
                "depthBaselineCandidates(): the panorama (", pano.num_views,
                " views of ", pano.depth_width, "x", pano.depth_height,
                ") does not match the panorama config (", panorama.num_views,
                " views of ", width, "x", height, ")");

  // step 1: nearest obstacle range per heading bin
  const float inf = std::numeric_limits<float>::infinity();
  std::array<float, kNumHeadings> obstacle;
  obstacle.fill(inf);
  const sim::CameraIntrinsics camera{width, height, depth.camera.hfov};
  const float viewStep = 2.0f * kPi / static_cast<float>(pano.num_views);
  const float scale =
      depth.normalize_depth ? depth.max_depth - depth.min_depth : 1.0f;
  const float offset = depth.normalize_depth ? depth.min_depth : 0.0f;
  // the far clip stands for "nothing within range", never an obstacle
  const float far = depth.max_depth * 0.999f;
  for (int view = 0; view < pano.num_views; ++view) {
    const float* image =
        pano.depth.data() + static_cast<size_t>(view) * width * height;
    for (int column = 0; column < width; ++column) {
      const float x =
          sim::pixelDirection(camera, static_cast<float>(column), 0.0f).x();
      // camera +X is to the right, so a column right of the axis turns
      // clockwise: negative relative heading
      const float azimuth = -std::atan(x);
      // each heading reads the view whose axis is nearest
      if (std::abs(azimuth) > 0.5f * viewStep + 1e-6f) continue;
      const int bin = headingBin(static_cast<float>(view) * viewStep + azimuth);
      const float lateral = std::sqrt(1.0f + x * x);
      for (int row = 0; row < height; ++row) {
        const float metres = offset + scale * image[row * width + column];
        if (metres >= far) continue;
        const float y =
            sim::pixelDirection(camera, 0.0f, static_cast<float>(row)).y();
        const float above = depth.camera.position_y + metres * y;
        const bool body =
            above > config.floor_tolerance && above < config.body_height;
        const bool drop = above < -config.drop_tolerance;
        if (!body && !drop) continue;
        float& nearest = obstacle[static_cast<size_t>(bin)];
        nearest = std::min(nearest, metres * lateral);
      }
    }
  }

  // step 2: the corridor along each heading
  DepthBaselineResult result;
  for (int h = 0; h < kNumHeadings; ++h) {
    float free = depth.max_depth;
    for (int other = 0; other < kNumHeadings; ++other) {
      const float range = obstacle[static_cast<size_t>(other)];
      if (!std::isfinite(range)) continue;
      const float angle = static_cast<float>(other - h) * kHeadingStep;
      const float along = range * std::cos(angle);
      if (along <= 0.0f) continue;
      if (std::abs(range * std::sin(angle)) < config.half_width)
        free = std::min(free, along);
    }
    result.free[static_cast<size_t>(h)] = free;
  }

  // step 3: the widest-open headings, kept apart
  std::vector<int> order(kNumHeadings);
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
    return result.free[static_cast<size_t>(a)] >
           result.free[static_cast<size_t>(b)];
  });
  for (int h : order) {
    if (static_cast<int>(result.candidates.size()) >= config.max_candidates)
      break;
    const float free = result.free[static_cast<size_t>(h)];
    if (free < config.min_free) break;
    const bool near = std::any_of(
        result.candidates.begin(), result.candidates.end(),
        [&](const Candidate& c) {
          const int gap = std::abs(c.heading_bin - h);
          return std::min(gap, kNumHeadings - gap) <= config.nms_radius;
        });
    if (near) continue;
    const float distance = std::clamp(free - config.clearance, kDistanceStep,
                                      kNumDistances * kDistanceStep);
    result.candidates.push_back(candidateAt(h, distanceBin(distance), free));
  }
  return result;
}

}  // namespace vln::waypoint
