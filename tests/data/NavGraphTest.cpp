#include "data/NavGraph.h"

#include <cmath>
#include <limits>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "common/Json.h"
#include "support/TestPaths.h"

namespace vln::data {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;

// A square a-b-c-d of side 3 m (y is up, so it lies in the x-z plane) with
// a long diagonal shortcut missing, plus an isolated node e:
//
//   a(0,0) --- b(3,0)
//     |          |
//   d(0,3) --- c(3,3)        e(10,10)
NavGraph squareGraph() {
  NavGraph g;
  g.addNode("a", {0, 0, 0});
  g.addNode("b", {3, 0, 0});
  g.addNode("c", {3, 0, 3});
  g.addNode("d", {0, 0, 3});
  g.addNode("e", {10, 0, 10});
  g.addEdge("a", "b");
  g.addEdge("b", "c");
  g.addEdge("c", "d");
  g.addEdge("d", "a");
  return g;
}

TEST(NavGraphTest, NeighboursAreSymmetricAndSorted) {
  NavGraph g = squareGraph();
  g.addEdge("b", "a");  // repeated edge in the other direction is ignored
  EXPECT_EQ(g.numNodes(), 5);
  EXPECT_EQ(g.numEdges(), 4);
  const int a = g.indexOf("a");
  EXPECT_THAT(g.neighbors(a), ElementsAre(g.indexOf("b"), g.indexOf("d")));
  EXPECT_TRUE(g.adjacent(g.indexOf("c"), g.indexOf("b")));
  EXPECT_FALSE(g.adjacent(a, g.indexOf("c")));
  EXPECT_TRUE(g.neighbors(g.indexOf("e")).empty());
  EXPECT_EQ(g.find("zzz"), -1);
}

TEST(NavGraphTest, ShortestPathsUseEuclideanEdgeWeights) {
  NavGraph g = squareGraph();
  const int a = g.indexOf("a"), b = g.indexOf("b"), c = g.indexOf("c");
  // no diagonal edge: a -> c goes around the square (3 + 3), not 3*sqrt(2)
  EXPECT_DOUBLE_EQ(g.distance(a, c), 6.0);
  EXPECT_DOUBLE_EQ(g.euclidean(a, c), std::sqrt(18.0));
  EXPECT_DOUBLE_EQ(g.distance(b, b), 0.0);
  EXPECT_EQ(g.distance(a, g.indexOf("e")),
            std::numeric_limits<double>::infinity());
  EXPECT_TRUE(g.shortestPath(a, g.indexOf("e")).empty());
  EXPECT_THAT(g.shortestPath(a, b), ElementsAre(a, b));
  EXPECT_THAT(g.shortestPath(a, a), ElementsAre(a));

  // adding a shorter detour through a new node changes the route
  g.addNode("m", {1.5f, 0.0f, 1.5f});
  g.addEdge("a", "m");
  g.addEdge("m", "c");
  EXPECT_NEAR(g.distance(a, c), std::sqrt(18.0), 1e-6);
  EXPECT_THAT(g.shortestPath(a, c), ElementsAre(a, g.indexOf("m"), c));
}

TEST(NavGraphTest, NearestNodeIsThreeDimensional) {
  NavGraph g;
  g.addNode("ground", {0, 0, 0});
  g.addNode("upstairs", {0, 3, 0.5f});
  // horizontally nearer to "upstairs", but 3 m below it
  EXPECT_EQ(g.nearestNode({0.0f, 0.2f, 0.6f}), g.indexOf("ground"));
  EXPECT_EQ(g.nearestNode({0.0f, 2.5f, 0.6f}), g.indexOf("upstairs"));
  EXPECT_EQ(NavGraph().nearestNode({0, 0, 0}), -1);
}

TEST(NavGraphTest, JsonRoundTrip) {
  test::TempDir dir;
  const NavGraph g = squareGraph();
  writeNavGraph(dir / "g.json.gz", g);
  const NavGraph back = readNavGraph(dir / "g.json.gz");
  ASSERT_EQ(back.numNodes(), g.numNodes());
  EXPECT_EQ(back.numEdges(), g.numEdges());
  for (int i = 0; i < g.numNodes(); ++i) {
    const int j = back.indexOf(g.node(i).id);
    EXPECT_EQ(back.node(j).position, g.node(i).position);
  }
  EXPECT_EQ(navGraphToJson(back), navGraphToJson(g));
  EXPECT_EQ(navGraphToJson(g)["edges"][0], nlohmann::json({"a", "b"}));
}

TEST(NavGraphTest, MalformedFilesNameTheFileAndField) {
  test::TempDir dir;
  auto expectError = [&](const std::string& text, const std::string& what) {
    const auto file = test::writeText(dir / "bad.json", text);
    EXPECT_THAT([&] { readNavGraph(file); },
                ::testing::ThrowsMessage<std::invalid_argument>(
                    ::testing::AllOf(HasSubstr("bad.json"), HasSubstr(what))))
        << text;
  };
  expectError(R"({"edges": []})", "field 'nodes' is missing");
  expectError(R"({"nodes": {}})", "field 'edges' is missing");
  expectError(R"({"nodes": {"a": [0, 1]}, "edges": []})", "'nodes.a'");
  expectError(R"({"nodes": {"a": [0, "x", 1]}, "edges": []})", "'nodes.a[1]'");
  expectError(R"({"nodes": {"a": [0, 0, 0]}, "edges": [["a", "q"]]})",
              "'edges[0][1]' names unknown node 'q'");
  expectError(R"({"nodes": {"a": [0, 0, 0]}, "edges": [["a", "a"]]})",
              "self-loop");
  expectError(R"({"nodes": {"a": [0, 0, 0]}, "edges": [["a"]]})", "'edges[0]'");
  expectError(R"([1, 2])", "expected a JSON object");
}

TEST(NavGraphTest, ProgrammaticErrorsNameTheId) {
  NavGraph g;
  g.addNode("a", {0, 0, 0});
  EXPECT_THAT(
      [&] {
        g.addNode("a", {1, 0, 0});
      },
      ::testing::ThrowsMessage<std::invalid_argument>(
          HasSubstr("duplicate node id 'a'")));
  EXPECT_THAT([&] { g.addEdge("a", "b"); },
              ::testing::ThrowsMessage<std::invalid_argument>(
                  HasSubstr("unknown node id 'b'")));
  EXPECT_THAT([&] { g.indexOf("b"); },
              ::testing::ThrowsMessage<std::invalid_argument>(
                  HasSubstr("no node with id 'b'")));
  EXPECT_THAT(
      [&] {
        g.addNode("n", {std::numeric_limits<float>::quiet_NaN(), 0, 0});
      },
      ::testing::ThrowsMessage<std::invalid_argument>(
          HasSubstr("non-finite position")));
}

}  // namespace
}  // namespace vln::data
