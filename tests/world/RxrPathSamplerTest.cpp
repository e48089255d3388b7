#include "world/RxrPathSampler.h"

#include <gtest/gtest.h>

#include <cmath>
#include <optional>
#include <set>
#include <string>

namespace vln::world {
namespace {

// A 5 x 5 grid of nodes 2 m apart, joined to their 4-neighbours.
data::NavGraph gridGraph() {
  data::NavGraph graph;
  for (int r = 0; r < 5; ++r)
    for (int c = 0; c < 5; ++c)
      graph.addNode(std::to_string(r * 5 + c),
                    Vec3f(2.0f * static_cast<float>(c), 0.0f,
                          -2.0f * static_cast<float>(r)));
  for (int r = 0; r < 5; ++r)
    for (int c = 0; c < 5; ++c) {
      if (c + 1 < 5)
        graph.addEdge(std::to_string(r * 5 + c), std::to_string(r * 5 + c + 1));
      if (r + 1 < 5)
        graph.addEdge(std::to_string(r * 5 + c),
                      std::to_string((r + 1) * 5 + c));
    }
  return graph;
}

TEST(RxrPathSamplerTest, WalksFollowEdgesWithoutRevisitsWithinTheLimits) {
  const data::NavGraph graph = gridGraph();
  RxrTrajectoryConfig config;
  config.min_nodes = 8;
  config.max_nodes = 10;
  config.min_length = 10.0f;
  config.max_length = 30.0f;
  config.min_goal_distance = 3.0f;
  config.max_turn = 90.0f;  // no U-turns on the grid
  int found = 0;
  for (uint64_t seed = 0; seed < 200; ++seed) {
    const std::optional<GraphPath> walk = sampleRxrWalk(graph, config, seed);
    if (!walk) continue;
    ++found;
    EXPECT_GE(walk->size(), 8u);
    EXPECT_LE(walk->size(), 10u);
    EXPECT_EQ(std::set<int>(walk->begin(), walk->end()).size(), walk->size());
    for (size_t i = 1; i < walk->size(); ++i)
      EXPECT_TRUE(graph.adjacent((*walk)[i - 1], (*walk)[i]));
    const double length = pathLength(graph, *walk);
    EXPECT_GE(length, 10.0);
    EXPECT_LE(length, 30.0);
    const Vec3f span =
        graph.node(walk->back()).position - graph.node(walk->front()).position;
    EXPECT_GE(std::hypot(span.x(), span.z()), 3.0f);
    // the same seed draws the same walk
    EXPECT_EQ(sampleRxrWalk(graph, config, seed), walk);
  }
  EXPECT_GT(found, 20);
}

TEST(RxrPathSamplerTest, TooFewNodesOrATightTurnLimitGiveNoWalk) {
  const data::NavGraph graph = gridGraph();
  RxrTrajectoryConfig config;
  config.min_nodes = 30;
  config.max_nodes = 30;
  EXPECT_FALSE(sampleRxrWalk(graph, config, 1).has_value());
  // straight lines only: at most 5 nodes on a 5 x 5 grid
  config.min_nodes = 8;
  config.max_nodes = 8;
  config.max_turn = 0.0f;
  for (uint64_t seed = 0; seed < 50; ++seed)
    EXPECT_FALSE(sampleRxrWalk(graph, config, seed).has_value());
}

}  // namespace
}  // namespace vln::world
