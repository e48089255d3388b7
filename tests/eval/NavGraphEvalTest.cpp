#include "eval/NavGraphEval.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "support/TestPaths.h"

namespace vln::eval {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;

// A corridor along -Z with a side room and a far end (y is up):
//
//   n0(0,0) - n1(0,-2) - n2(0,-4) - n3(0,-6) - n5(0,-10)
//               |
//             n4(2,-2)                       n6(0,-9): on no edge
//
// (x, z) given; every node is on the floor, y = 0.
data::NavGraph corridor() {
  data::NavGraph g;
  g.addNode("n0", {0, 0, 0});
  g.addNode("n1", {0, 0, -2});
  g.addNode("n2", {0, 0, -4});
  g.addNode("n3", {0, 0, -6});
  g.addNode("n4", {2, 0, -2});
  g.addNode("n5", {0, 0, -10});
  g.addNode("n6", {0, 0, -9});
  g.addEdge("n0", "n1");
  g.addEdge("n1", "n2");
  g.addEdge("n2", "n3");
  g.addEdge("n1", "n4");
  g.addEdge("n3", "n5");
  return g;
}

TEST(NavGraphEvalTest, SnappingMovesAtMostOneHopPerPosition) {
  const data::NavGraph g = corridor();
  auto id = [&](const char* name) { return g.indexOf(name); };
  const std::vector<Vec3f> positions{
      {0, 0, 0},     {0, 0, -0.9f},  // still nearer n0 (0.9) than n1 (1.1)
      {0, 0, -1.2f},                 // n1
      {0, 0, -5.5f},  // nearest overall is n3, but from n1 only n2 is reachable
      {0, 0, -5.6f},  // now n3 is a neighbour
      {0, 0, -5.6f},  // repeated position: no new node
  };
  EXPECT_THAT(snapPathToGraph(g, id("n0"), positions),
              ElementsAre(id("n0"), id("n1"), id("n2"), id("n3")));
}

TEST(NavGraphEvalTest, SnappingOscillatesAndKeepsTiesOnTheCurrentNode) {
  const data::NavGraph g = corridor();
  auto id = [&](const char* name) { return g.indexOf(name); };
  // into the side room and back: the path zig-zags n1 -> n4 -> n1
  const std::vector<Vec3f> positions{
      {0, 0, -2}, {1.5f, 0, -2}, {0.2f, 0, -2}, {1.0f, 0, -2}};
  // the last point is 1 m from both n1 and n4: it stays on n1
  EXPECT_THAT(snapPathToGraph(g, id("n1"), positions),
              ElementsAre(id("n1"), id("n4"), id("n1")));
  // a single position is just the start node
  EXPECT_THAT(snapPathToGraph(g, id("n2"), std::vector<Vec3f>{{9, 9, 9}}),
              ElementsAre(id("n2")));
}

TEST(NavGraphEvalTest, ScoresMatchR2rEvalByHand) {
  const data::NavGraph g = corridor();
  auto id = [&](const char* name) { return g.indexOf(name); };
  // n0 -> n1 -> n4 -> n1 -> n2, goal n3
  const std::vector<int> path{id("n0"), id("n1"), id("n4"), id("n1"), id("n2")};
  const GraphEpisodeMetrics m = scoreGraphPath(g, path, id("n3"));
  EXPECT_DOUBLE_EQ(m.path_length, 8.0);
  EXPECT_DOUBLE_EQ(m.distance_to_goal, 2.0);
  EXPECT_DOUBLE_EQ(m.shortest_path_length, 6.0);
  EXPECT_DOUBLE_EQ(m.oracle_error, 2.0);
  EXPECT_EQ(m.success, 1.0);
  EXPECT_EQ(m.oracle_success, 1.0);
  EXPECT_DOUBLE_EQ(m.spl, 0.75);  // 6 / max(8, 6)
  EXPECT_EQ(m.trajectory_steps, 4.0);
}

TEST(NavGraphEvalTest, ErrorMarginIsStrictAndOracleCanSucceedAlone) {
  data::NavGraph g = corridor();
  auto id = [&](const char* name) { return g.indexOf(name); };
  // n0 -> n1, goal n5 at graph distance 8 from n1: passes n3? no; fails
  const std::vector<int> shortPath{id("n0"), id("n1")};
  GraphEpisodeMetrics m = scoreGraphPath(g, shortPath, id("n5"));
  EXPECT_EQ(m.success, 0.0);
  EXPECT_EQ(m.spl, 0.0);
  EXPECT_DOUBLE_EQ(m.distance_to_goal, 8.0);
  // ends exactly 3 m away (n2 is 2 + 4 = 6 from n5; n1-n2 is 2; use a goal
  // 3 m down a new spur from n2)
  g.addNode("spur", {3, 0, -4});
  g.addEdge("n2", "spur");
  const std::vector<int> toN2{id("n1"), id("n2")};
  m = scoreGraphPath(g, toN2, g.indexOf("spur"));
  EXPECT_DOUBLE_EQ(m.distance_to_goal, 3.0);
  EXPECT_EQ(m.success, 0.0);  // eval.py: nav_error < error_margin
  EXPECT_EQ(m.oracle_success, 0.0);
  // passing by the goal and walking on: oracle success only
  const std::vector<int> past{id("n0"), id("n1"), id("n2"), id("n3"), id("n5")};
  m = scoreGraphPath(g, past, id("n1"));
  EXPECT_EQ(m.success, 0.0);
  EXPECT_EQ(m.oracle_success, 1.0);
  EXPECT_DOUBLE_EQ(m.oracle_error, 0.0);
}

TEST(NavGraphEvalTest, ContinuousEpisodeEndToEnd) {
  const data::NavGraph g = corridor();
  // reference path through n0..n3 on the floor, slightly off the node points
  const std::vector<Vec3f> reference{
      {0.1f, 0, 0}, {0, 0, -2}, {0, 0, -4.1f}, {0, 0, -6}};
  std::vector<Vec3f> agent;
  for (int i = 0; i <= 24; ++i) agent.push_back({0, 0, -0.25f * i});
  const GraphEpisodeMetrics m = scoreContinuousPath(g, agent, reference, "ep9");
  EXPECT_EQ(m.success, 1.0);
  EXPECT_DOUBLE_EQ(m.path_length, 6.0);
  EXPECT_DOUBLE_EQ(m.spl, 1.0);
  EXPECT_EQ(m.trajectory_steps, 3.0);

  // a reference path from another scene is caught
  const std::vector<Vec3f> elsewhere{{50, 0, 50}, {0, 0, -6}};
  EXPECT_THAT([&] { scoreContinuousPath(g, agent, elsewhere, "ep9"); },
              ::testing::ThrowsMessage<std::invalid_argument>(::testing::AllOf(
                  HasSubstr("episode 'ep9'"), HasSubstr("wrong scene graph"))));
  // a disconnected node cannot be scored
  const std::vector<int> stray{g.indexOf("n6")};
  EXPECT_THAT([&] { scoreGraphPath(g, stray, g.indexOf("n0")); },
              ::testing::ThrowsMessage<std::invalid_argument>(
                  HasSubstr("'n6' is not connected")));
}

TEST(NavGraphEvalTest, StatsAggregateAndRoundTrip) {
  const data::NavGraph g = corridor();
  auto id = [&](const char* name) { return g.indexOf(name); };
  const std::vector<int> good{id("n0"), id("n1"), id("n2"), id("n3")};
  const std::vector<int> bad{id("n0")};
  const std::vector<GraphEpisodeMetrics> episodes{
      scoreGraphPath(g, good, id("n3")), scoreGraphPath(g, bad, id("n3"))};
  const GraphSplitStats stats = aggregateGraph(episodes);
  EXPECT_EQ(stats.num_episodes, 2);
  EXPECT_DOUBLE_EQ(stats.mean.success, 0.5);
  EXPECT_DOUBLE_EQ(stats.mean.path_length, 3.0);
  EXPECT_DOUBLE_EQ(stats.mean.distance_to_goal, 3.0);

  test::TempDir dir;
  const auto file = writeGraphStatsFile(dir.path(), 4, "val_seen", stats);
  EXPECT_EQ(file.filename(), "navgraph_stats_ckpt_4_val_seen.json");
  EXPECT_EQ(readGraphStatsFile(file), stats);
  test::writeText(dir / "bad.json", R"({"path_length": 1})");
  EXPECT_THAT([&] { readGraphStatsFile(dir / "bad.json"); },
              ::testing::ThrowsMessage<std::invalid_argument>(::testing::AllOf(
                  HasSubstr("bad.json"), HasSubstr("'distance_to_goal'"))));
}

}  // namespace
}  // namespace vln::eval
