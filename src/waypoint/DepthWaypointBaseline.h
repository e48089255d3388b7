#pragma once
// A geometry-only candidate-waypoint predictor: open directions read from
// the depth panorama alone, no learning, no nav-graph. It is the reference
// the learned predictor must beat (issue 18), in the spirit of the
// "free space" heuristics that preceded learned waypoint predictors.
//
//  1. Obstacles: every depth pixel of a level panorama is lifted to its
//     3-D point. A point higher than `floor_tolerance` above the feet and
//     lower than `body_height` (something the body would hit), or more than
//     `drop_tolerance` below the feet (the floor drops away), is an
//     obstacle at its horizontal range, in the heading bin of its column.
//     Each heading bin reads the view whose optical axis is nearest.
//  2. Free distance per heading: how far a corridor of half-width
//     `half_width` along that heading stays clear of every obstacle point
//     binned above, capped at the depth camera's max_depth.
//  3. Candidates: headings in decreasing free distance, each at least
//     `min_free` and more than `nms_radius` bins from those already taken,
//     up to `max_candidates`; the waypoint stands `clearance` short of the
//     free distance, clamped to the heatmap's 0.25-3.0 m.
//
// Heading convention: waypoint/WaypointHeatmap.h.

#include <array>
#include <vector>

#include "common/Config.h"
#include "sim/Panorama.h"
#include "sim/SimConfig.h"
#include "waypoint/WaypointHeatmap.h"

namespace vln::waypoint {

struct DepthBaselineConfig {
  int max_candidates = 5;
  int nms_radius = 7;  ///< heading bins (Hong et al.'s NMS box)
  float min_free = 1.0f;
  float clearance = 0.5f;
  float half_width = 0.2f;
  float floor_tolerance = 0.2f;
  float body_height = 1.5f;
  float drop_tolerance = 0.35f;

  void visit(common::ConfigVisitor& v) {
    v.field("max_candidates", max_candidates, "Most candidates per panorama",
            common::inRange(1, kNumHeadings));
    v.field("nms_radius", nms_radius,
            "Candidates lie more than this many heading bins (3 degrees) "
            "apart",
            common::inRange(0, kNumHeadings / 2));
    v.field("min_free", min_free,
            "A heading needs this much free distance to be a candidate (m)",
            common::inRange(0.0, 100.0));
    v.field("clearance", clearance,
            "The waypoint stops this far short of the obstacle (m)",
            common::inRange(0.0, 10.0));
    v.field("half_width", half_width,
            "Half-width of the corridor that must be free (m; about the "
            "agent's radius plus a margin)",
            common::inRange(0.0, 5.0));
    v.field("floor_tolerance", floor_tolerance,
            "Points within this height of the feet are floor (m; the "
            "navmesh's agent_max_climb)",
            common::inRange(0.0, 2.0));
    v.field("body_height", body_height,
            "Points above this height over the feet are not obstacles (m; "
            "the navmesh's agent_height)",
            common::inRange(0.1, 10.0));
    v.field("drop_tolerance", drop_tolerance,
            "Points this far below the feet mean the floor drops away (m; "
            "above floor_tolerance because the navmesh may sit up to a "
            "voxel above the floor)",
            common::inRange(0.0, 10.0));
  }
  bool operator==(const DepthBaselineConfig&) const = default;
};

struct DepthBaselineResult {
  /// Free distance per heading bin, metres (step 2).
  std::array<float, kNumHeadings> free{};
  /// Step 3, by decreasing free distance; score = free distance.
  std::vector<Candidate> candidates;
};

/// Runs the baseline on a level panorama rendered with `panorama` (its depth
/// camera's size, HFOV, height and depth post-processing). Throws
/// std::invalid_argument when the panorama does not match the config or the
/// baseline config is out of range.
DepthBaselineResult depthBaselineCandidates(const sim::Panorama& pano,
                                            const sim::PanoramaConfig& panorama,
                                            const DepthBaselineConfig& config);

}  // namespace vln::waypoint
