#include "world/TrajectorySampler.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <set>
#include <string>
#include <utility>

#include "common/Check.h"

namespace vln::world {
namespace {

// Ten nodes on a line along +x, 2 m apart.
data::NavGraph lineGraph() {
  data::NavGraph graph;
  for (int i = 0; i < 10; ++i)
    graph.addNode(strCat("n", i), Vec3f(2.0f * i, 1.5f, 0.0f));
  for (int i = 0; i + 1 < 10; ++i)
    graph.addEdge(strCat("n", i), strCat("n", i + 1));
  return graph;
}

// A 5 x 5 grid, 2 m pitch, 4-connected plus one diagonal shortcut row.
data::NavGraph gridGraph() {
  data::NavGraph graph;
  auto id = [](int i, int j) { return strCat("g", i * 5 + j); };
  for (int i = 0; i < 5; ++i)
    for (int j = 0; j < 5; ++j)
      graph.addNode(id(i, j), Vec3f(2.0f * i, 1.4f, 2.0f * j));
  for (int i = 0; i < 5; ++i) {
    for (int j = 0; j < 5; ++j) {
      if (i + 1 < 5) graph.addEdge(id(i, j), id(i + 1, j));
      if (j + 1 < 5) graph.addEdge(id(i, j), id(i, j + 1));
      if (i + 1 < 5 && j + 1 < 5 && j == 0)
        graph.addEdge(id(i, j), id(i + 1, j + 1));
    }
  }
  return graph;
}

TEST(TrajectorySamplerTest, LineGraphHasExactlyTheAdmissiblePairs) {
  const data::NavGraph graph = lineGraph();
  TrajectoryConfig config;  // 4-7 nodes, 5-16 m
  const TrajectorySampler sampler(graph, config);
  // k edges (k+1 nodes, 2k metres) is admissible for k in 3..6, and a line
  // of 10 nodes has 2 * (10 - k) ordered pairs k apart
  int expected = 0;
  for (int k = 3; k <= 6; ++k) expected += 2 * (10 - k);
  EXPECT_EQ(sampler.size(), expected);
}

TEST(TrajectorySamplerTest, CandidatesAreShortestAdmissiblePaths) {
  const data::NavGraph graph = gridGraph();
  TrajectoryConfig config;
  config.min_nodes = 4;
  config.max_nodes = 6;
  config.min_length = 5.0f;
  config.max_length = 11.0f;
  const TrajectorySampler sampler(graph, config);
  ASSERT_GT(sampler.size(), 20);
  std::set<std::pair<int, int>> pairs;
  for (const GraphPath& path : sampler.candidates()) {
    const int nodes = static_cast<int>(path.size());
    EXPECT_GE(nodes, config.min_nodes);
    EXPECT_LE(nodes, config.max_nodes);
    const double length = pathLength(graph, path);
    EXPECT_GE(length, config.min_length);
    EXPECT_LE(length, config.max_length);
    for (size_t i = 1; i < path.size(); ++i)
      EXPECT_TRUE(graph.adjacent(path[i - 1], path[i]));
    // a shortest path: no shorter route between its ends
    EXPECT_NEAR(length, graph.distance(path.front(), path.back()), 1e-6);
    EXPECT_TRUE(pairs.emplace(path.front(), path.back()).second)
        << "pair repeated";
  }
}

TEST(TrajectorySamplerTest, ShuffleIsADeterministicPermutation) {
  const data::NavGraph graph = gridGraph();
  const TrajectorySampler sampler(graph, TrajectoryConfig{});
  ASSERT_GT(sampler.size(), 10);
  const auto a = sampler.shuffledOrder(7);
  const auto b = sampler.shuffledOrder(7);
  const auto c = sampler.shuffledOrder(8);
  EXPECT_EQ(a, b);
  EXPECT_NE(a, c);
  auto sorted = a;
  std::sort(sorted.begin(), sorted.end());
  for (int i = 0; i < sampler.size(); ++i)
    EXPECT_EQ(sorted[static_cast<size_t>(i)], i);

  const auto sample = sampler.sample(5, 7);
  ASSERT_EQ(sample.size(), 5u);
  for (size_t i = 0; i < sample.size(); ++i)
    EXPECT_EQ(sample[i], sampler.candidate(a[i]));
  EXPECT_EQ(sampler.sample(100000, 7).size(),
            static_cast<size_t>(sampler.size()));
}

TEST(TrajectorySamplerTest, DisconnectedGraphGivesNoCrossingPaths) {
  data::NavGraph graph;
  for (int i = 0; i < 6; ++i)
    graph.addNode(strCat("a", i), Vec3f(2.0f * i, 1.5f, 0.0f));
  for (int i = 0; i < 6; ++i)
    graph.addNode(strCat("b", i), Vec3f(2.0f * i, 1.5f, 50.0f));
  for (int i = 0; i + 1 < 6; ++i) {
    graph.addEdge(strCat("a", i), strCat("a", i + 1));
    graph.addEdge(strCat("b", i), strCat("b", i + 1));
  }
  const TrajectorySampler sampler(graph, TrajectoryConfig{});
  ASSERT_GT(sampler.size(), 0);
  for (const GraphPath& path : sampler.candidates())
    EXPECT_EQ(path.front() < 6, path.back() < 6);
}

TEST(TrajectorySamplerTest, InvalidRangesAreRejected) {
  const data::NavGraph graph = lineGraph();
  TrajectoryConfig config;
  config.min_nodes = 6;
  config.max_nodes = 4;
  EXPECT_THROW(TrajectorySampler(graph, config), std::invalid_argument);
}

}  // namespace
}  // namespace vln::world
