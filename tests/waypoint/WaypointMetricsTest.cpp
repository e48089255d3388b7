// Tests src/waypoint/WaypointMetrics.cpp: candidates, %Open, d_C and d_H on
// hand-built nodes with answers worked out by hand.

#include "waypoint/WaypointMetrics.h"

#include <gtest/gtest.h>

#include <cmath>

#include <nlohmann/json.hpp>

namespace vln::waypoint {
namespace {

// An agent at the origin facing -Z, open 3 m in every direction, and
// targets at the given world points (horizontal).
NodeTargets nodeWithTargets(const std::vector<Vec3f>& points) {
  NodeTargets node;
  node.agent = {Vec3f::Zero(), 0.0f};
  node.open.fill(3.0f);
  for (const Vec3f& p : points) {
    TargetWaypoint t;
    t.position = p;
    t.polar = toPolar(node.agent, p);
    t.heading_bin = headingBin(t.polar.heading);
    t.distance_bin = distanceBin(t.polar.distance);
    node.targets.push_back(t);
  }
  return node;
}

TEST(WaypointMetricsTest, PerfectPredictionScoresZero) {
  // 2 m ahead (-Z) and 1 m left (-X): both exactly on cell centres
  const NodeTargets node =
      nodeWithTargets({Vec3f(0.0f, 0.0f, -2.0f), Vec3f(-1.0f, 0.0f, 0.0f)});
  const NodeScore score = scoreCandidates(
      {candidateAt(0, 7, 1.0f), candidateAt(30, 3, 1.0f)}, node);
  EXPECT_EQ(score.candidates, 2);
  EXPECT_EQ(score.targets, 2);
  EXPECT_EQ(score.open, 2);
  ASSERT_TRUE(score.scored);
  EXPECT_NEAR(score.chamfer, 0.0, 1e-6);
  EXPECT_NEAR(score.hausdorff, 0.0, 1e-6);
}

TEST(WaypointMetricsTest, ChamferAndHausdorffByHand) {
  // targets 2 m ahead and 2 m behind; one prediction 1 m ahead:
  // prediction -> nearest target 1 m; targets -> prediction 1 m and 3 m;
  // d_C = 0.5 * (1 + (1 + 3) / 2) = 1.5, d_H = max(1, 3) = 3
  const NodeTargets node =
      nodeWithTargets({Vec3f(0.0f, 0.0f, -2.0f), Vec3f(0.0f, 0.0f, 2.0f)});
  const NodeScore one = scoreCandidates({candidateAt(0, 3, 1.0f)}, node);
  ASSERT_TRUE(one.scored);
  EXPECT_NEAR(one.chamfer, 1.5, 1e-5);
  EXPECT_NEAR(one.hausdorff, 3.0, 1e-5);

  // adding a prediction 1 m to the left: both targets are sqrt(5) m from
  // it, so it is the one behind's nearest now; predictions' mean and
  // targets' mean are both (1 + sqrt 5) / 2, d_H = sqrt 5
  const NodeScore two = scoreCandidates(
      {candidateAt(0, 3, 1.0f), candidateAt(30, 3, 1.0f)}, node);
  EXPECT_NEAR(two.chamfer, (1.0 + std::sqrt(5.0)) / 2.0, 1e-5);
  EXPECT_NEAR(two.hausdorff, std::sqrt(5.0), 1e-5);
}

TEST(WaypointMetricsTest, OpenCountsCandidatesWithinTheOpenDistance) {
  NodeTargets node = nodeWithTargets({Vec3f(0.0f, 0.0f, -2.0f)});
  node.open[0] = 1.1f;  // 4 whole steps: cells 0.25 .. 1.0 m
  node.open[45] = 3.0f;
  const NodeScore score =
      scoreCandidates({candidateAt(0, 3, 1.0f), candidateAt(0, 4, 1.0f),
                       candidateAt(45, 11, 1.0f)},
                      node);
  EXPECT_EQ(score.open, 2);  // 1.0 m ahead and 3.0 m at bin 45; not 1.25 m
  EXPECT_TRUE(isOpen(1.0f, 3));
  EXPECT_TRUE(isOpen(0.9999999f, 3));  // a float step short is still a step
  EXPECT_FALSE(isOpen(0.99f, 3));
  EXPECT_FALSE(isOpen(0.2f, 0));
}

TEST(WaypointMetricsTest, NodesWithoutCandidatesAreCountedNotAveraged) {
  const NodeTargets node = nodeWithTargets({Vec3f(0.0f, 0.0f, -2.0f)});
  PredictorMetrics metrics;
  metrics.add(scoreCandidates({}, node));
  // d_C 0.5 * (1 + 1) = 1, d_H 1; the candidate is open
  metrics.add(scoreCandidates({candidateAt(0, 3, 1.0f)}, node));
  // two candidates for one target: delta +1; d_C = 0.5 * ((1 + 0) / 2 + 0)
  metrics.add(scoreCandidates(
      {candidateAt(0, 3, 1.0f), candidateAt(0, 7, 1.0f)}, node));
  EXPECT_EQ(metrics.nodes, 3);
  EXPECT_EQ(metrics.empty, 1);
  EXPECT_EQ(metrics.scored, 2);
  EXPECT_DOUBLE_EQ(metrics.candidatesPerNode(), 1.0);
  EXPECT_DOUBLE_EQ(metrics.meanDelta(), 0.0);  // (-1 + 0 + 1) / 3
  EXPECT_DOUBLE_EQ(metrics.meanAbsDelta(), 2.0 / 3.0);
  EXPECT_DOUBLE_EQ(metrics.openShare(), 1.0);
  EXPECT_NEAR(metrics.meanChamfer(), (1.0 + 0.25) / 2.0, 1e-6);
  EXPECT_NEAR(metrics.meanHausdorff(), (1.0 + 1.0) / 2.0, 1e-6);

  PredictorMetrics twice = metrics;
  twice.merge(metrics);
  EXPECT_EQ(twice.nodes, 6);
  EXPECT_NEAR(twice.meanChamfer(), metrics.meanChamfer(), 1e-12);
  EXPECT_EQ(metrics.toJson()["empty"], 1);
  EXPECT_EQ(PredictorMetrics{}.openShare(), 0.0);
}

}  // namespace
}  // namespace vln::waypoint
