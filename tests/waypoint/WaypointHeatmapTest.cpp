// Tests src/waypoint/WaypointHeatmap.cpp: the bins, the heading convention
// (counter-clockwise, heading 0 along -Z) and Hong et al.'s NMS on
// hand-built heatmaps.

#include "waypoint/WaypointHeatmap.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace vln::waypoint {
namespace {

using ::testing::HasSubstr;

TEST(WaypointHeatmapTest, BinsAreThreeDegreesAndQuarterMetres) {
  EXPECT_FLOAT_EQ(binHeading(0), 0.0f);
  EXPECT_FLOAT_EQ(binHeading(30), kPi / 2.0f);
  EXPECT_FLOAT_EQ(binDistance(0), 0.25f);
  EXPECT_FLOAT_EQ(binDistance(11), 3.0f);
  // nearest bin, wrapping: -1 degree is bin 0, -2 degrees bin 119
  EXPECT_EQ(headingBin(degToRad(-1.0f)), 0);
  EXPECT_EQ(headingBin(degToRad(-2.0f)), 119);
  EXPECT_EQ(headingBin(degToRad(361.0f)), 0);
  EXPECT_EQ(headingBin(degToRad(91.0f)), 30);
  EXPECT_EQ(headingBin(degToRad(178.6f)), 60);
  // nearest distance centre; out of range below 0.125 and from 3.125 m
  EXPECT_EQ(distanceBin(0.1f), -1);
  EXPECT_EQ(distanceBin(0.2f), 0);
  EXPECT_EQ(distanceBin(2.2f), 8);  // 2.25 m, where flooring would say 2.0
  EXPECT_EQ(distanceBin(3.1f), 11);
  EXPECT_EQ(distanceBin(3.2f), -1);
  EXPECT_EQ(distanceBin(std::nanf("")), -1);
}

TEST(WaypointHeatmapTest, PolarHeadingsGoCounterClockwiseFromTheAgent) {
  const sim::AgentState agent{Vec3f(1.0f, 0.2f, 2.0f), 0.0f};
  // heading 0 looks along -Z; counter-clockwise (left) is -X
  const Polar ahead = toPolar(agent, Vec3f(1.0f, 0.0f, 0.0f));
  EXPECT_NEAR(ahead.heading, 0.0f, 1e-6f);
  EXPECT_NEAR(ahead.distance, 2.0f, 1e-6f);
  const Polar left = toPolar(agent, Vec3f(-0.5f, 0.0f, 2.0f));
  EXPECT_NEAR(left.heading, kPi / 2.0f, 1e-6f);
  EXPECT_NEAR(left.distance, 1.5f, 1e-6f);
  EXPECT_EQ(headingBin(left.heading), 30);
  const Polar right =
      toPolar(agent, Vec3f(3.0f, 5.0f, 2.0f));  // height ignored
  EXPECT_NEAR(right.heading, -kPi / 2.0f, 1e-6f);
  EXPECT_EQ(headingBin(right.heading), 90);
  // relative to a turned agent: facing -X, the point at -X is ahead
  const sim::AgentState turned{agent.position, kPi / 2.0f};
  EXPECT_NEAR(toPolar(turned, Vec3f(-0.5f, 0.0f, 2.0f)).heading, 0.0f, 1e-6f);
  // fromPolar inverts toPolar
  for (float heading : {0.3f, -2.0f, 3.0f}) {
    const Vec3f p = fromPolar(turned, heading, 1.7f);
    const Polar back = toPolar(turned, p);
    EXPECT_NEAR(back.heading, heading, 1e-5f);
    EXPECT_NEAR(back.distance, 1.7f, 1e-5f);
    EXPECT_FLOAT_EQ(p.y(), turned.position.y());
  }
}

// a heatmap with the given cells set
std::vector<float> heatmapWith(
    const std::vector<std::tuple<int, int, float>>& cells) {
  std::vector<float> heatmap(kHeatmapSize, 0.0f);
  for (const auto& [h, d, v] : cells)
    heatmap[static_cast<size_t>(h * kNumDistances + d)] = v;
  return heatmap;
}

TEST(WaypointHeatmapTest, NmsKeepsPeaksAndSuppressesTheirBoxes) {
  // (10, 4) suppresses (16, 2) (6 bins, 2 distances away) but not (18, 4)
  // (8 bins) nor (10, 10) (6 distances away, but in the same heading: one
  // candidate per heading); (117, 4) is 7 bins from (4, 4) across the wrap
  const auto heatmap = heatmapWith({{10, 4, 0.9f},
                                    {16, 2, 0.8f},
                                    {18, 4, 0.7f},
                                    {10, 10, 0.6f},
                                    {4, 4, 0.5f},
                                    {117, 4, 0.4f},
                                    {60, 0, 0.3f}});
  const std::vector<Candidate> picks = heatmapNms(heatmap, 5, 7, 5);
  // (4, 4) is 6 bins from (10, 4): suppressed; (117, 4) then survives
  ASSERT_EQ(picks.size(), 4u);
  EXPECT_EQ(picks[0], candidateAt(10, 4, 0.9f));
  EXPECT_EQ(picks[1], candidateAt(18, 4, 0.7f));
  EXPECT_EQ(picks[2], candidateAt(117, 4, 0.4f));
  EXPECT_EQ(picks[3], candidateAt(60, 0, 0.3f));
  EXPECT_FLOAT_EQ(picks[3].distance, 0.25f);
  EXPECT_FLOAT_EQ(picks[2].heading, binHeading(117));

  // at most maxCandidates, and nothing at or below minScore
  EXPECT_EQ(heatmapNms(heatmap, 2, 7, 5).size(), 2u);
  EXPECT_EQ(heatmapNms(heatmap, 5, 7, 5, /*minScore=*/0.5f).size(), 2u);
  EXPECT_TRUE(heatmapNms(std::vector<float>(kHeatmapSize, 0.0f)).empty());
  // the wrap: (119, 0) suppresses (5, 0) with radius 7 (6 bins apart)
  const auto wrapped = heatmapNms(heatmapWith({{119, 0, 1.0f}, {5, 0, 0.9f}}));
  ASSERT_EQ(wrapped.size(), 1u);
  EXPECT_EQ(wrapped[0].heading_bin, 119);
}

TEST(WaypointHeatmapTest, NmsRejectsAHeatmapOfTheWrongSize) {
  try {
    heatmapNms(std::vector<float>(100, 0.0f));
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("heatmapNms(): heatmap has 100 values"));
  }
}

}  // namespace
}  // namespace vln::waypoint
