#include "waypoint/WaypointHeatmap.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>

#include "common/Check.h"

namespace vln::waypoint {

float binHeading(int h) {
  VLN_ASSERT(h >= 0 && h < kNumHeadings);
  return static_cast<float>(h) * kHeadingStep;
}

float binDistance(int d) {
  VLN_ASSERT(d >= 0 && d < kNumDistances);
  return static_cast<float>(d + 1) * kDistanceStep;
}

int headingBin(float radians) {
  // nearest bin on the circle: bin 0 covers [-1.5, 1.5) degrees
  const float wrapped =
      radians - 2.0f * kPi * std::floor(radians / (2.0f * kPi));
  const int bin = static_cast<int>(std::lround(wrapped / kHeadingStep));
  return bin % kNumHeadings;
}

int distanceBin(float metres) {
  // nearest bin centre (Hong et al. floor the distance instead, putting a
  // 2.2 m neighbour at 2.0 m; the nearest centre halves the worst error)
  const long bin = std::lround(metres / kDistanceStep) - 1;
  if (!(metres >= 0.5f * kDistanceStep) || bin < 0 || bin >= kNumDistances)
    return -1;
  return static_cast<int>(bin);
}

Polar toPolar(const sim::AgentState& agent, const Vec3f& target) {
  const float dx = target.x() - agent.position.x();
  const float dz = target.z() - agent.position.z();
  // heading 0 looks along -Z and grows counter-clockwise (towards -X)
  const float absolute = std::atan2(-dx, -dz);
  return {wrapAngle(absolute - agent.heading), std::hypot(dx, dz)};
}

Vec3f fromPolar(const sim::AgentState& agent, float heading, float distance) {
  const float absolute = agent.heading + heading;
  return agent.position + Vec3f(-std::sin(absolute) * distance, 0.0f,
                                -std::cos(absolute) * distance);
}

Candidate candidateAt(int h, int d, float score) {
  return {h, d, binHeading(h), binDistance(d), score};
}

std::vector<Candidate> heatmapNms(std::span<const float> heatmap,
                                  int maxCandidates, int headingRadius,
                                  int distanceRadius, float minScore) {
  VLN_CHECK_ARG(heatmap.size() == static_cast<size_t>(kHeatmapSize),
                "heatmapNms(): heatmap has ", heatmap.size(),
                " values, expected ", kHeatmapSize, " (", kNumHeadings, " x ",
                kNumDistances, ")");
  VLN_CHECK_ARG(maxCandidates >= 0 && headingRadius >= 0 && distanceRadius >= 0,
                "heatmapNms(): maxCandidates, headingRadius and "
                "distanceRadius must be >= 0, got ",
                maxCandidates, ", ", headingRadius, ", ", distanceRadius);
  std::vector<float> suppressed(heatmap.begin(), heatmap.end());
  std::vector<bool> headingTaken(kNumHeadings, false);
  std::vector<Candidate> picks;
  for (int round = 0; round < maxCandidates; ++round) {
    const auto best = std::max_element(suppressed.begin(), suppressed.end());
    // suppressed cells hold -inf, so an exhausted map stops here too
    if (!(*best > minScore)) break;
    const int index = static_cast<int>(best - suppressed.begin());
    const int h = index / kNumDistances;
    const int d = index % kNumDistances;
    if (!headingTaken[static_cast<size_t>(h)])
      picks.push_back(candidateAt(h, d, heatmap[static_cast<size_t>(index)]));
    headingTaken[static_cast<size_t>(h)] = true;
    // the box around the pick, wrapping in heading
    for (int dh = -headingRadius; dh <= headingRadius; ++dh) {
      const int row = ((h + dh) % kNumHeadings + kNumHeadings) % kNumHeadings;
      for (int dd = std::max(0, d - distanceRadius);
           dd <= std::min(kNumDistances - 1, d + distanceRadius); ++dd)
        suppressed[static_cast<size_t>(row * kNumDistances + dd)] =
            -std::numeric_limits<float>::infinity();
    }
  }
  return picks;
}

}  // namespace vln::waypoint
