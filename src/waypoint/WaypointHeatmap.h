#pragma once
// The candidate-waypoint heatmap that targets, predictors and waypoint
// agents share (docs/waypoints.md): 120 relative headings x 12 distances
// around the agent, as Hong et al.'s predictor (CVPR 2022) outputs it.
//
// Layout: a float array [kNumHeadings, kNumDistances], heading-major, index
// heading * kNumDistances + distance. Heading bin h is the relative heading
// h * 3 degrees COUNTER-CLOCKWISE from the agent's heading seen from above
// (+Y up), the sign of AgentState::heading and the order of the panorama's
// views (sim/Panorama.h): with 12 views, bin 10k is the optical axis of
// view k. Hong et al. index their heatmap clockwise; bin h here is their
// bin (120 - h) % 120. Distance bin d is (d + 1) * 0.25 m, 0.25..3.0 m.
// Distances are horizontal (x, z), metres; positions world frame.

#include <span>
#include <vector>

#include "common/Math.h"
#include "sim/Agent.h"

namespace vln::waypoint {

inline constexpr int kNumHeadings = 120;
inline constexpr int kNumDistances = 12;
inline constexpr int kHeatmapSize = kNumHeadings * kNumDistances;
/// Width of a distance bin and distance of bin 0, metres.
inline constexpr float kDistanceStep = 0.25f;
/// Width of a heading bin, radians (3 degrees).
inline constexpr float kHeadingStep = 2.0f * kPi / kNumHeadings;

/// Relative heading of bin `h` (radians, counter-clockwise, in [0, 2*pi)).
float binHeading(int h);
/// Distance of bin `d`, metres: (d + 1) * kDistanceStep.
float binDistance(int d);
/// The heading bin nearest to relative heading `radians` (any value;
/// wrapped).
int headingBin(float radians);
/// The distance bin nearest to `metres`, or -1 outside
/// [0.5, kNumDistances + 0.5) * kDistanceStep (0.125 to 3.125 m).
int distanceBin(float metres);

/// Relative heading (radians, counter-clockwise from the agent's heading,
/// wrapped to (-pi, pi]) and horizontal distance (m) of `target` from an
/// agent at `agent`.
struct Polar {
  float heading = 0.0f;
  float distance = 0.0f;
};
Polar toPolar(const sim::AgentState& agent, const Vec3f& target);
/// The world point at relative `heading` (radians, counter-clockwise) and
/// horizontal `distance` (m) from the agent, at the agent's height.
Vec3f fromPolar(const sim::AgentState& agent, float heading, float distance);

/// One candidate waypoint: its cell and what it means.
struct Candidate {
  int heading_bin = 0;
  int distance_bin = 0;
  float heading = 0.0f;   ///< relative, radians, counter-clockwise
  float distance = 0.0f;  ///< horizontal, metres
  float score = 0.0f;     ///< heatmap value (or the baseline's free space)
  bool operator==(const Candidate&) const = default;
};

/// The candidate of cell (h, d), at the bin centres, with `score`.
Candidate candidateAt(int h, int d, float score);

/// Hong et al.'s non-maximum suppression: repeatedly takes the highest cell
/// and zeroes the box of +-`headingRadius` bins (circular) x
/// +-`distanceRadius` bins around it, at most `maxCandidates` times, and
/// keeps the picks whose value is above `minScore`; a heading bin yields at
/// most one candidate (their evaluation keeps one distance per heading).
/// Their settings are 5, 7, 5 on a softmax over the heatmap. `heatmap` has
/// kHeatmapSize values in the layout above. Candidates are ordered by
/// decreasing score.
std::vector<Candidate> heatmapNms(std::span<const float> heatmap,
                                  int maxCandidates = 5, int headingRadius = 7,
                                  int distanceRadius = 5,
                                  float minScore = 0.0f);

}  // namespace vln::waypoint
