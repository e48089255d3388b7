#include "rollout/Metrics.h"

#include <cmath>
#include <limits>
#include <random>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "common/Json.h"
#include "support/TestPaths.h"

namespace vln::rollout {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;
using Path = std::vector<std::pair<int, int>>;

// Flat empty floor: the geodesic distance is the straight-line distance.
float euclid(const Vec3f& a, const Vec3f& b) { return (a - b).norm(); }

// A straight corridor walked with VLN-CE's 0.25 m forward steps along -Z,
// then STOP (which repeats the last position).
EpisodeRecord straightEpisode(int forwardSteps, bool stop) {
  EpisodeRecord r;
  r.episode_id = "straight";
  for (int i = 0; i <= forwardSteps; ++i) {
    r.positions.push_back({0.0f, 0.0f, -0.25f * i});
    r.headings.push_back(0.0f);
    if (i > 0) r.actions.push_back(1);
  }
  if (stop) {
    r.positions.push_back(r.positions.back());
    r.headings.push_back(0.0f);
    r.actions.push_back(0);
  }
  r.called_stop = stop;
  r.steps_taken = static_cast<int>(r.actions.size());
  r.goal = {0.0f, 0.0f, -0.25f * forwardSteps};
  r.reference_path = {r.positions.front(), r.goal};
  r.start_distance = 0.25 * forwardSteps;
  return r;
}

// Episode that walks from the origin to `end` in one move and stops.
EpisodeRecord stopAt(const Vec3f& end, const Vec3f& goal) {
  EpisodeRecord r;
  r.episode_id = "stop-at";
  r.positions = {Vec3f::Zero(), end, end};
  r.actions = {1, 0};
  r.called_stop = true;
  r.steps_taken = 2;
  r.goal = goal;
  r.reference_path = {Vec3f::Zero(), goal};
  r.start_distance = goal.norm();
  return r;
}

std::vector<Vec3d> points3(std::initializer_list<double> xs) {
  std::vector<Vec3d> out;
  for (double x : xs) out.emplace_back(x, 0.0, 0.0);
  return out;
}

// Sum of point distances along a warping path, checking it is a valid
// monotone path from (0, 0) to (n-1, m-1).
double pathCost(const Path& path, const std::vector<Vec3d>& a,
                const std::vector<Vec3d>& b) {
  EXPECT_EQ(path.front(), std::make_pair(0, 0));
  EXPECT_EQ(path.back(), std::make_pair(static_cast<int>(a.size()) - 1,
                                        static_cast<int>(b.size()) - 1));
  double cost = 0.0;
  for (size_t k = 0; k < path.size(); ++k) {
    if (k > 0) {
      const int di = path[k].first - path[k - 1].first;
      const int dj = path[k].second - path[k - 1].second;
      EXPECT_TRUE(di >= 0 && di <= 1 && dj >= 0 && dj <= 1 && di + dj > 0)
          << "step " << k;
    }
    cost += (a[path[k].first] - b[path[k].second]).norm();
  }
  return cost;
}

std::vector<Vec3d> randomWalk(std::mt19937_64& rng, int n, double step) {
  std::normal_distribution<double> noise(0.0, step);
  std::vector<Vec3d> out{Vec3d::Zero()};
  while (static_cast<int>(out.size()) < n)
    out.push_back(out.back() + Vec3d(noise(rng), 0.1 * noise(rng), noise(rng)));
  return out;
}

// ---------------------------------------------------------------------------
// episode metrics
// ---------------------------------------------------------------------------

TEST(MetricsTest, StraightLineToTheGoal) {
  const EpisodeRecord r = straightEpisode(/*forwardSteps=*/8, /*stop=*/true);
  const EpisodeMetrics m = computeEpisodeMetrics(r, euclid);
  EXPECT_DOUBLE_EQ(m.path_length, 2.0);
  EXPECT_DOUBLE_EQ(m.distance_to_goal, 0.0);
  EXPECT_EQ(m.success, 1.0);
  EXPECT_EQ(m.oracle_success, 1.0);
  EXPECT_DOUBLE_EQ(m.spl, 1.0);
  EXPECT_EQ(m.steps_taken, 9.0);  // 8 forward + STOP
  // agent path (0, -0.25, ..., -2) against reference (0, -2): every agent
  // point is matched to its nearer end, cost = 2*(0.25+0.5+0.75) + 1
  // (the midpoint -1 is 1 m from both) = 4
  EXPECT_NEAR(m.ndtw, std::exp(-4.0 / (2 * 3.0)), 1e-6);
  EXPECT_DOUBLE_EQ(m.sdtw, m.ndtw);
}

TEST(MetricsTest, DetourHalvesSpl) {
  EpisodeRecord r;
  r.episode_id = "detour";
  r.goal = {0, 0, -2};
  r.positions = {{0, 0, 0}, {1, 0, 0}, {1, 0, -2}, {0, 0, -2}, {0, 0, -2}};
  r.called_stop = true;
  r.steps_taken = 4;
  r.reference_path = {{0, 0, 0}, {0, 0, -2}};
  r.start_distance = 2.0;
  const EpisodeMetrics m = computeEpisodeMetrics(r, euclid);
  EXPECT_DOUBLE_EQ(m.path_length, 4.0);
  EXPECT_EQ(m.success, 1.0);
  EXPECT_DOUBLE_EQ(m.spl, 0.5);  // 2 / max(2, 4)
}

TEST(MetricsTest, NeverStoppingFailsEvenAtTheGoal) {
  // the step limit ends the episode on the goal without STOP
  const EpisodeRecord r = straightEpisode(/*forwardSteps=*/8, /*stop=*/false);
  const EpisodeMetrics m = computeEpisodeMetrics(r, euclid);
  EXPECT_DOUBLE_EQ(m.distance_to_goal, 0.0);
  EXPECT_EQ(m.success, 0.0);
  EXPECT_EQ(m.spl, 0.0);
  EXPECT_EQ(m.sdtw, 0.0);
  EXPECT_EQ(m.oracle_success, 1.0);
  EXPECT_GT(m.ndtw, 0.0);
  EXPECT_EQ(m.steps_taken, 8.0);
}

TEST(MetricsTest, SuccessRadiusIsStrict) {
  const Vec3f goal{0, 0, -10};
  auto at = [&](float d) {
    return computeEpisodeMetrics(stopAt({0, 0, -10 + d}, goal), euclid);
  };
  EXPECT_EQ(at(2.99f).success, 1.0);
  EXPECT_EQ(at(2.99f).oracle_success, 1.0);
  EXPECT_EQ(at(3.01f).success, 0.0);
  EXPECT_EQ(at(3.01f).oracle_success, 0.0);
  // habitat-lab Success: distance_to_target < SUCCESS_DISTANCE
  EXPECT_TRUE(isSuccess(true, 2.999999));
  EXPECT_FALSE(isSuccess(true, 3.0));
  EXPECT_FALSE(isSuccess(false, 0.0));
}

TEST(MetricsTest, OracleSuccessIncludesTheStart) {
  // starts 2.5 m from the goal, walks away to 5 m and stops there
  EpisodeRecord r = stopAt({0, 0, 2.5f}, {0, 0, -2.5f});
  const EpisodeMetrics m = computeEpisodeMetrics(r, euclid);
  EXPECT_EQ(m.oracle_success, 1.0);
  EXPECT_EQ(m.success, 0.0);
  EXPECT_DOUBLE_EQ(m.distance_to_goal, 5.0);
}

TEST(MetricsTest, DistancesAreGeodesicButPathLengthIsEuclidean3d) {
  // a wall makes every geodesic twice the straight line; a stair step
  // rises 0.3 m while moving 0.4 m
  auto walled = [](const Vec3f& a, const Vec3f& b) {
    return 2.0f * (a - b).norm();
  };
  EpisodeRecord r = stopAt({0, 0.3f, -0.4f}, {0, 0.3f, -2.4f});
  const EpisodeMetrics m = computeEpisodeMetrics(r, walled);
  EXPECT_NEAR(m.path_length, 0.5, 1e-6);
  EXPECT_NEAR(m.distance_to_goal, 4.0, 1e-6);
  EXPECT_EQ(m.success, 0.0);  // 2 m away in a straight line, 4 m by geodesic
}

TEST(MetricsTest, SplEdgeCases) {
  EXPECT_DOUBLE_EQ(splScore(true, 5.0, 4.0), 1.0);  // shorter than d0 clamps
  EXPECT_DOUBLE_EQ(splScore(true, 5.0, 10.0), 0.5);
  EXPECT_DOUBLE_EQ(splScore(false, 5.0, 5.0), 0.0);
  EXPECT_DOUBLE_EQ(splScore(true, 0.0, 0.0), 1.0);
}

TEST(MetricsTest, InconsistentRecordsAreRejectedNamingTheEpisode) {
  EpisodeRecord r = straightEpisode(4, true);
  r.steps_taken = 3;  // e.g. the step limit counted wrongly
  EXPECT_THAT(
      [&] { computeEpisodeMetrics(r, euclid); },
      ::testing::ThrowsMessage<std::invalid_argument>(::testing::AllOf(
          HasSubstr("episode 'straight'"), HasSubstr("steps_taken + 1"))));
  r = straightEpisode(4, true);
  r.called_stop = false;  // yet the last action is STOP
  EXPECT_THAT([&] { computeEpisodeMetrics(r, euclid); },
              ::testing::ThrowsMessage<std::invalid_argument>(
                  HasSubstr("the last action is 0")));
  r = straightEpisode(4, true);
  r.reference_path.clear();
  EXPECT_THAT([&] { computeEpisodeMetrics(r, euclid); },
              ::testing::ThrowsMessage<std::invalid_argument>(
                  HasSubstr("'reference_path' is empty")));
  r = straightEpisode(4, true);
  auto unreachable = [](const Vec3f&, const Vec3f&) {
    return std::numeric_limits<float>::infinity();
  };
  EXPECT_THAT(
      [&] { computeEpisodeMetrics(r, unreachable); },
      ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("not finite")));
}

TEST(MetricsTest, NdtwDeduplicatesRepeatedPositions) {
  // turning in place and stopping add repeated positions; VLN-CE keeps a
  // position only when it changed, so they cost nothing
  const std::vector<Vec3f> reference{{0, 0, 0}, {0, 0, -1}, {0, 0, -2}};
  const std::vector<Vec3f> moving{{0, 0, 0}, {0, 0, -1}, {0, 0, -2}};
  const std::vector<Vec3f> withTurns{{0, 0, 0},  {0, 0, 0},  {0, 0, 0},
                                     {0, 0, -1}, {0, 0, -1}, {0, 0, -2},
                                     {0, 0, -2}};
  EXPECT_DOUBLE_EQ(ndtwScore(moving, reference), 1.0);
  EXPECT_DOUBLE_EQ(ndtwScore(withTurns, reference), 1.0);
  EXPECT_EQ(dedupConsecutive(withTurns).size(), 3u);
  // a stationary agent: DTW = 0 + 1 + 2, normaliser = 3 points * 3 m
  EXPECT_NEAR(ndtwScore(std::vector<Vec3f>{{0, 0, 0}}, reference),
              std::exp(-3.0 / 9.0), 1e-12);
}

// ---------------------------------------------------------------------------
// DTW and FastDTW
// ---------------------------------------------------------------------------

TEST(MetricsTest, DtwKnownSequences) {
  // the docstring example of both the fastdtw and dtw packages
  const std::vector<double> x{1, 2, 3, 4, 5}, y{2, 3, 4};
  const DtwResult exact = dtw1d(x, y);
  EXPECT_DOUBLE_EQ(exact.distance, 2.0);
  EXPECT_EQ(exact.path, (Path{{0, 0}, {1, 0}, {2, 1}, {3, 2}, {4, 2}}));
  const DtwResult fast = fastDtw1d(x, y);
  EXPECT_DOUBLE_EQ(fast.distance, 2.0);
  EXPECT_EQ(fast.path, (Path{{0, 0}, {1, 0}, {2, 1}, {3, 2}, {4, 2}}));

  // unequal lengths by hand: a = 0,1,2 and b = 0,2 along x; the middle point
  // of a is 1 m from either point of b
  const auto a = points3({0, 1, 2}), b = points3({0, 2});
  EXPECT_DOUBLE_EQ(dtw(a, b).distance, 1.0);
  EXPECT_DOUBLE_EQ(dtw(b, a).distance, 1.0);
  // fastdtw's 2-D test case, (i, i) points: 2 * sqrt(2)
  std::vector<Vec3d> d5, d3;
  for (int i = 1; i <= 5; ++i) d5.emplace_back(i, i, 0);
  for (int i = 2; i <= 4; ++i) d3.emplace_back(i, i, 0);
  EXPECT_NEAR(dtw(d5, d3).distance, 2.0 * std::sqrt(2.0), 1e-12);
  EXPECT_NEAR(fastDtw(d5, d3).distance, 2.0 * std::sqrt(2.0), 1e-12);
  // single points
  EXPECT_DOUBLE_EQ(dtw(points3({3}), points3({0, 1, 5})).distance, 3 + 2 + 2);
  EXPECT_THAT([&] { dtw({}, a); }, ::testing::Throws<std::invalid_argument>());
  EXPECT_THAT(
      [&] { fastDtw(a, b, 0); },
      ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("radius")));
}

TEST(MetricsTest, FastDtwEqualsExactOnShortSequences) {
  // below radius + 2 = 3 points fastdtw falls back to full DTW
  std::mt19937_64 rng(7);
  for (int n = 1; n <= 2; ++n) {
    for (int m = 1; m <= 12; ++m) {
      const auto a = randomWalk(rng, n, 0.5), b = randomWalk(rng, m, 0.5);
      EXPECT_DOUBLE_EQ(fastDtw(a, b).distance, dtw(a, b).distance);
      EXPECT_DOUBLE_EQ(fastDtw(b, a).distance, dtw(b, a).distance);
    }
  }
  // a radius covering everything makes the window complete (fastdtw docs)
  for (int trial = 0; trial < 20; ++trial) {
    const auto a = randomWalk(rng, 9 + trial, 0.5);
    const auto b = randomWalk(rng, 5 + trial / 2, 0.5);
    EXPECT_NEAR(fastDtw(a, b, /*radius=*/40).distance, dtw(a, b).distance,
                1e-9);
  }
}

TEST(MetricsTest, FastDtwPathsAreValidAndBoundExactDtw) {
  std::mt19937_64 rng(11);
  int strictlyWorse = 0;
  for (int trial = 0; trial < 300; ++trial) {
    const int n = 1 + static_cast<int>(rng() % 40);
    const int m = 1 + static_cast<int>(rng() % 40);
    const auto a = randomWalk(rng, n, 0.4), b = randomWalk(rng, m, 0.4);
    const DtwResult fast = fastDtw(a, b);
    const DtwResult exact = dtw(a, b);
    EXPECT_NEAR(pathCost(fast.path, a, b), fast.distance, 1e-9);
    EXPECT_NEAR(pathCost(exact.path, a, b), exact.distance, 1e-9);
    EXPECT_GE(fast.distance, exact.distance - 1e-9) << n << "x" << m;
    if (fast.distance > exact.distance + 1e-9) ++strictlyWorse;
  }
  // the window really restricts the search on some of these
  EXPECT_GT(strictlyWorse, 0);
}

TEST(MetricsTest, FastDtwIsCloseOnLongPaths) {
  // agent-like paths: a noisy copy of a 60-point reference walked with
  // three times as many points, as the agent's 0.25 m steps are denser
  std::mt19937_64 rng(3);
  std::normal_distribution<double> noise(0.0, 0.15);
  for (int trial = 0; trial < 5; ++trial) {
    const auto reference = randomWalk(rng, 60, 0.6);
    std::vector<Vec3d> agent;
    for (size_t i = 0; i + 1 < reference.size(); ++i)
      for (int k = 0; k < 3; ++k)
        agent.push_back(reference[i] +
                        (reference[i + 1] - reference[i]) * k / 3.0 +
                        Vec3d(noise(rng), 0.0, noise(rng)));
    const double exact = dtw(agent, reference).distance;
    const double fast = fastDtw(agent, reference).distance;
    EXPECT_GE(fast, exact - 1e-9);
    EXPECT_LT(fast, exact * 1.05) << "trial " << trial;
    // what nDTW reports differs by well under 0.01
    EXPECT_NEAR(std::exp(-fast / (60 * 3.0)), std::exp(-exact / (60 * 3.0)),
                0.01);
  }
}

TEST(MetricsTest, NdtwMethodsAgreeOnEpisodes) {
  EpisodeRecord r = straightEpisode(12, true);
  r.reference_path = {{0, 0, 0}, {0.1f, 0, -1}, {0, 0, -2}, {-0.1f, 0, -3}};
  MetricsOptions fast;
  fast.dtw = DtwMethod::kFast;
  const double exact = computeEpisodeMetrics(r, euclid).ndtw;
  const double approx = computeEpisodeMetrics(r, euclid, fast).ndtw;
  EXPECT_LE(approx, exact + 1e-12);
  EXPECT_NEAR(approx, exact, 0.01);
}

// ---------------------------------------------------------------------------
// aggregation and files
// ---------------------------------------------------------------------------

TEST(MetricsTest, AggregateAveragesEveryKey) {
  EpisodeMetrics a, b;
  a.distance_to_goal = 1.0;
  a.success = 1.0;
  a.spl = 0.8;
  a.ndtw = 0.6;
  a.sdtw = 0.6;
  a.path_length = 10.0;
  a.oracle_success = 1.0;
  a.steps_taken = 40;
  b.distance_to_goal = 7.0;
  b.ndtw = 0.2;
  b.path_length = 4.0;
  b.steps_taken = 500;
  const std::vector<EpisodeMetrics> both{a, b};
  const SplitStats s = aggregate(both);
  EXPECT_EQ(s.num_episodes, 2);
  EXPECT_DOUBLE_EQ(s.mean.distance_to_goal, 4.0);
  EXPECT_DOUBLE_EQ(s.mean.success, 0.5);
  EXPECT_DOUBLE_EQ(s.mean.spl, 0.4);
  EXPECT_DOUBLE_EQ(s.mean.ndtw, 0.4);
  EXPECT_DOUBLE_EQ(s.mean.sdtw, 0.3);
  EXPECT_DOUBLE_EQ(s.mean.path_length, 7.0);
  EXPECT_DOUBLE_EQ(s.mean.oracle_success, 0.5);
  EXPECT_DOUBLE_EQ(s.mean.steps_taken, 270.0);
  EXPECT_THAT([] { aggregate({}); },
              ::testing::Throws<std::invalid_argument>());
}

// ONE and oracle SPL by hand from VLN-CE's definitions (measures.py:
// OracleNavigationError, min over the path with the start; v1 OracleSPL,
// d0 / max(d0, TL so far) at the first step ending within 3 m)
TEST(MetricsTest, OracleNavigationErrorAndOracleSplFollowVlnCe) {
  EpisodeRecord r;
  r.episode_id = "detour";
  // goal at z = -10, start 5 m away; a 4 m detour sideways (6.40 m away),
  // 5 m to 2 m from the goal (inside 3 m: TL so far 9), 5 m away again
  // (7 m from the goal) and STOP
  r.goal = {0, 0, -10};
  r.positions = {{0, 0, -5}, {4, 0, -5}, {0, 0, -8}, {0, 0, -3}, {0, 0, -3}};
  r.actions = {1, 1, 1, 0};
  r.steps_taken = 4;
  r.called_stop = true;
  r.reference_path = {r.positions.front(), r.goal};
  r.start_distance = 5.0;
  const EpisodeMetrics m = computeEpisodeMetrics(r, euclid);
  EXPECT_DOUBLE_EQ(m.oracle_navigation_error, 2.0);
  EXPECT_EQ(m.oracle_success, 1.0);
  EXPECT_DOUBLE_EQ(m.oracle_spl, 5.0 / 9.0);
  EXPECT_EQ(m.success, 0.0);
  EXPECT_EQ(m.spl, 0.0);
  EXPECT_DOUBLE_EQ(m.distance_to_goal, 7.0);

  // never within 3 m: oracle SPL 0, ONE the nearest approach
  const EpisodeMetrics far =
      computeEpisodeMetrics(stopAt({0, 0, -6}, {0, 0, -10}), euclid);
  EXPECT_DOUBLE_EQ(far.oracle_navigation_error, 4.0);
  EXPECT_EQ(far.oracle_spl, 0.0);

  // ONE counts the start (VLN-CE updates it on reset); oracle SPL only
  // positions after a step: 2 m away at the start, one 1 m step closer
  const EpisodeMetrics near =
      computeEpisodeMetrics(stopAt({0, 0, -1}, {0, 0, -2}), euclid);
  EXPECT_DOUBLE_EQ(near.oracle_navigation_error, 1.0);
  EXPECT_DOUBLE_EQ(near.oracle_spl, 1.0);  // 2 / max(2, 1)
  EXPECT_DOUBLE_EQ(near.spl, 1.0);
  EpisodeRecord away = stopAt({0, 0, 1}, {0, 0, -2});
  const EpisodeMetrics awayMetrics = computeEpisodeMetrics(away, euclid);
  EXPECT_DOUBLE_EQ(awayMetrics.oracle_navigation_error, 2.0);
  EXPECT_EQ(awayMetrics.oracle_success, 1.0);
  EXPECT_EQ(awayMetrics.oracle_spl, 0.0);  // 3 m away after its step
}

TEST(MetricsTest, StatsFilesWrittenBeforeTheOracleMetricsStillRead) {
  test::TempDir dir;
  test::writeText(dir / "old.json",
                  R"({"distance_to_goal": 6.5, "success": 0.2, "spl": 0.1,
                      "ndtw": 0.4, "sdtw": 0.1, "path_length": 9.0,
                      "oracle_success": 0.3, "steps_taken": 40,
                      "num_episodes": 10})");
  const SplitStats old = readStatsFile(dir / "old.json");
  EXPECT_DOUBLE_EQ(old.mean.spl, 0.1);
  EXPECT_TRUE(std::isnan(old.mean.oracle_navigation_error));
  EXPECT_TRUE(std::isnan(old.mean.oracle_spl));
}

TEST(MetricsTest, StatsFileHasVlnceKeysAndRoundTrips) {
  test::TempDir dir;
  EpisodeMetrics m = computeEpisodeMetrics(straightEpisode(8, true), euclid);
  const std::vector<EpisodeMetrics> one{m};
  const SplitStats stats = aggregate(one);
  const auto file = writeStatsFile(dir.path(), 7, "val_unseen", stats);
  EXPECT_EQ(file.filename(), "stats_ckpt_7_val_unseen.json");
  const auto json = common::readJsonFile(file);
  for (const char* key :
       {"distance_to_goal", "success", "spl", "ndtw", "path_length",
        "oracle_success", "oracle_navigation_error", "oracle_spl",
        "steps_taken", "sdtw", "num_episodes"})
    EXPECT_TRUE(json.contains(key)) << key;
  EXPECT_EQ(readStatsFile(file), stats);

  test::writeText(dir / "bad.json", R"({"success": 1})");
  EXPECT_THAT([&] { readStatsFile(dir / "bad.json"); },
              ::testing::ThrowsMessage<std::invalid_argument>(::testing::AllOf(
                  HasSubstr("bad.json"), HasSubstr("'distance_to_goal'"))));
}

TEST(MetricsTest, EpisodesFileKeepsRxrPitchesAndLookActions) {
  // RxR's action space: LOOK_DOWN (5) then LOOK_UP (4) before walking,
  // with the cameras' pitch recorded per position
  EpisodeRecord rxr = straightEpisode(2, /*stop=*/true);
  rxr.positions.insert(rxr.positions.begin(), 2, rxr.positions.front());
  rxr.headings.insert(rxr.headings.begin(), 2, 0.0f);
  rxr.actions.insert(rxr.actions.begin(), {5, 4});
  rxr.steps_taken = static_cast<int>(rxr.actions.size());
  rxr.pitches.assign(rxr.positions.size(), 0.0f);
  rxr.pitches[1] = -0.5235988f;
  const std::vector<EpisodeResult> results = {
      {rxr, computeEpisodeMetrics(rxr, euclid)}};
  const nlohmann::json json = episodesToJson(results);
  const auto back = episodesFromJson(json, "rxr.json");
  ASSERT_EQ(back.size(), 1u);
  EXPECT_EQ(back[0].record.pitches, rxr.pitches);
  EXPECT_EQ(back[0].record.actions, rxr.actions);
  // looks move nothing: the metrics are the R2R walk's
  const EpisodeRecord r2r = straightEpisode(2, /*stop=*/true);
  EXPECT_EQ(back[0].metrics.path_length,
            computeEpisodeMetrics(r2r, euclid).path_length);

  // R2R records have no pitches, and their files no "pitches" key
  const nlohmann::json plain =
      episodesToJson(std::vector<EpisodeResult>{{r2r, {}}});
  EXPECT_FALSE(plain["episodes"][0]["path"].contains("pitches"));
  EXPECT_TRUE(episodesFromJson(plain, "r2r.json")[0].record.pitches.empty());

  // a pitch list of the wrong length and an action code beyond TELEPORT
  // (6, a teleporting waypoint agent's step) are named
  nlohmann::json bad = json;
  bad["episodes"][0]["path"]["pitches"].erase(0);
  EXPECT_THAT([&] { episodesFromJson(bad, "rxr.json"); },
              ::testing::ThrowsMessage<std::invalid_argument>(
                  HasSubstr("'path.pitches'")));
  bad = json;
  bad["episodes"][0]["actions"][0] = 7;
  EXPECT_THAT([&] { episodesFromJson(bad, "rxr.json"); },
              ::testing::ThrowsMessage<std::invalid_argument>(
                  HasSubstr("must be an action code 0..6, got 7")));
  nlohmann::json teleport = json;
  teleport["episodes"][0]["actions"][0] = 6;
  EXPECT_EQ(episodesFromJson(teleport, "rxr.json")[0].record.actions[0], 6);
}

TEST(MetricsTest, EpisodesFileKeepsWaypointChoices) {
  EpisodeRecord r = straightEpisode(3, /*stop=*/true);
  auto choice = [](Vec3f position, std::vector<Vec3f> candidates, int chosen) {
    WaypointChoice c;
    c.position = position;
    c.candidates = std::move(candidates);
    c.chosen = chosen;
    return c;
  };
  r.waypoint_choices = {choice({0, 0, 0}, {{0, 0, -1}, {1, 0, 0}}, 0),
                        choice({0, 0, -1}, {{0, 0, -2}}, -1),
                        choice({0, 0, -2}, {{0, 0, -3}, {1, 0, -2}}, 1)};
  // the goal oracle's verdict where the goal was known: one end
  // unreachable; within the stop distance nothing was planned
  r.waypoint_choices[0].oracle = 0;
  r.waypoint_choices[0].end_distances = {
      1.5f, std::numeric_limits<float>::infinity()};
  r.waypoint_choices[1].oracle = -1;
  r.waypoint_choices[2].clause = 3;  // the clause tracker's pointer
  const std::vector<EpisodeResult> results = {{r, {}}};
  const nlohmann::json json = episodesToJson(results);
  const nlohmann::json& written = json["episodes"][0]["waypoint_choices"];
  EXPECT_TRUE(written[0]["end_distances"][1].is_null());
  EXPECT_TRUE(written[1]["end_distances"].empty());
  EXPECT_FALSE(written[2].contains("oracle"));
  EXPECT_FALSE(written[2].contains("end_distances"));
  EXPECT_FALSE(written[0].contains("clause"));
  EXPECT_EQ(written[2]["clause"], 3);
  const auto back = episodesFromJson(json, "wp.json");
  ASSERT_EQ(back[0].record.waypoint_choices.size(), 3u);
  for (size_t k = 0; k < 3; ++k) {
    const WaypointChoice& got = back[0].record.waypoint_choices[k];
    EXPECT_EQ(got.position, r.waypoint_choices[k].position);
    EXPECT_EQ(got.candidates, r.waypoint_choices[k].candidates);
    EXPECT_EQ(got.chosen, r.waypoint_choices[k].chosen);
    EXPECT_EQ(got.oracle, r.waypoint_choices[k].oracle);
    EXPECT_EQ(got.end_distances, r.waypoint_choices[k].end_distances);
    EXPECT_EQ(got.clause, r.waypoint_choices[k].clause);
  }
  EXPECT_EQ(back[0].record.waypoint_choices[2].oracle,
            WaypointChoice::kNoOracle);
  // low-level agents' files have no such key
  EXPECT_FALSE(episodesToJson(std::vector<EpisodeResult>{
                                  {straightEpisode(3, true), {}}})["episodes"][0]
                   .contains("waypoint_choices"));
  // a choice beyond the candidates, and a malformed candidate, are named
  nlohmann::json bad = json;
  bad["episodes"][0]["waypoint_choices"][1]["chosen"] = 1;
  EXPECT_THAT([&] { episodesFromJson(bad, "wp.json"); },
              ::testing::ThrowsMessage<std::invalid_argument>(::testing::AllOf(
                  HasSubstr("wp.json"), HasSubstr("'waypoint_choices[1].chosen'"),
                  HasSubstr("got 1"))));
  bad = json;
  bad["episodes"][0]["waypoint_choices"][0]["candidates"][1] = "x";
  EXPECT_THAT([&] { episodesFromJson(bad, "wp.json"); },
              ::testing::ThrowsMessage<std::invalid_argument>(
                  HasSubstr("'waypoint_choices[0].candidates'")));
  // so are an oracle beyond the candidates and end distances that do not
  // match them
  bad = json;
  bad["episodes"][0]["waypoint_choices"][0]["oracle"] = 2;
  EXPECT_THAT([&] { episodesFromJson(bad, "wp.json"); },
              ::testing::ThrowsMessage<std::invalid_argument>(
                  HasSubstr("'waypoint_choices[0].oracle' must be -1")));
  bad = json;
  bad["episodes"][0]["waypoint_choices"][0]["end_distances"] = {1.0};
  EXPECT_THAT([&] { episodesFromJson(bad, "wp.json"); },
              ::testing::ThrowsMessage<std::invalid_argument>(
                  HasSubstr("'waypoint_choices[0].end_distances'")));
  bad = json;
  bad["episodes"][0]["waypoint_choices"][0]["end_distances"][0] = "far";
  EXPECT_THAT([&] { episodesFromJson(bad, "wp.json"); },
              ::testing::ThrowsMessage<std::invalid_argument>(
                  HasSubstr("must hold numbers or null, got string")));
  bad = json;
  bad["episodes"][0]["waypoint_choices"][0].erase("end_distances");
  EXPECT_THAT([&] { episodesFromJson(bad, "wp.json"); },
              ::testing::ThrowsMessage<std::invalid_argument>(
                  HasSubstr("end_distances")));
}

TEST(MetricsTest, EpisodesFileRoundTrips) {
  test::TempDir dir;
  std::vector<EpisodeResult> results;
  for (bool stop : {true, false}) {
    EpisodeRecord r = straightEpisode(5, stop);
    r.episode_id = stop ? "12" : "7";
    r.headings.back() = 0.5f;
    results.push_back({r, computeEpisodeMetrics(r, euclid)});
  }
  const auto file = dir / episodesFileName(3, "val_seen");
  EXPECT_EQ(file.filename(), "episodes_ckpt_3_val_seen.json.gz");
  writeEpisodesFile(file, results);
  const auto back = readEpisodesFile(file);
  ASSERT_EQ(back.size(), 2u);
  for (size_t i = 0; i < back.size(); ++i) {
    const auto& [r, m] = back[i];
    EXPECT_EQ(r.episode_id, results[i].record.episode_id);
    EXPECT_EQ(r.positions, results[i].record.positions);
    EXPECT_EQ(r.headings, results[i].record.headings);
    EXPECT_EQ(r.actions, results[i].record.actions);
    EXPECT_EQ(r.reference_path, results[i].record.reference_path);
    EXPECT_EQ(r.goal, results[i].record.goal);
    EXPECT_EQ(r.called_stop, results[i].record.called_stop);
    EXPECT_EQ(r.steps_taken, results[i].record.steps_taken);
    EXPECT_EQ(m, results[i].metrics);
  }

  auto json = episodesToJson(results);
  json["episodes"][1]["actions"][2] = 9;
  EXPECT_THAT(
      [&] { episodesFromJson(json, "eps.json"); },
      ::testing::ThrowsMessage<std::invalid_argument>(::testing::AllOf(
          HasSubstr("eps.json: episode '7'"), HasSubstr("'actions[2]'"))));
}

TEST(MetricsTest, LeaderboardFormat) {
  test::TempDir dir;
  EpisodeRecord stopped = straightEpisode(2, true);
  stopped.episode_id = "4";
  stopped.headings = {0.0f, 0.0f, 7.0f, 7.0f};  // wraps to 7 - 2 pi
  EpisodeRecord limit = straightEpisode(2, false);
  limit.episode_id = "10";
  const std::vector<EpisodeRecord> records{stopped, limit};
  writeLeaderboardFile(dir / "preds.json", records);

  const auto json = common::readJsonFile(dir / "preds.json");
  ASSERT_TRUE(json.contains("4"));
  ASSERT_EQ(json["4"].size(), 4u);  // start + 2 forward + STOP
  EXPECT_EQ(json["4"][0]["stop"], false);
  EXPECT_EQ(json["4"][3]["stop"], true);
  EXPECT_NEAR(json["4"][3]["heading"].get<double>(), 7.0 - 2.0 * M_PI, 1e-5);
  EXPECT_EQ(json["4"][1]["position"], nlohmann::json({0.0, 0.0, -0.25}));
  for (const auto& step : json["10"]) EXPECT_EQ(step["stop"], false);

  const auto back = readLeaderboardFile(dir / "preds.json");
  ASSERT_EQ(back.size(), 2u);
  EXPECT_EQ(back[0].first, "10");  // sorted by id as JSON object keys
  EXPECT_EQ(back[1].second, leaderboardSteps(stopped));

  EpisodeRecord noHeadings = stopped;
  noHeadings.headings.clear();
  EXPECT_THAT([&] { leaderboardSteps(noHeadings); },
              ::testing::ThrowsMessage<std::invalid_argument>(
                  HasSubstr("episode '4' needs one heading per position")));
}

// Real data: the shared val_seen sample's ground-truth locations scored
// against themselves and against their own start.
TEST(MetricsTest, SharedFixtureGroundTruthScoresPerfectly) {
  const auto gtFile = test::sharedFixturesPath() /
                      "r2r_vlnce_v1-3_preprocessed/val_seen_sample_gt.json.gz";
  if (!std::filesystem::exists(gtFile)) GTEST_SKIP() << gtFile << " absent";
  const auto gt = common::readJsonFile(gtFile);
  ASSERT_FALSE(gt.empty());
  for (const auto& [id, entry] : gt.items()) {
    std::vector<Vec3f> locations;
    for (const auto& p : entry.at("locations"))
      locations.emplace_back(p[0].get<float>(), p[1].get<float>(),
                             p[2].get<float>());
    ASSERT_GE(locations.size(), 2u) << id;
    EXPECT_DOUBLE_EQ(ndtwScore(locations, locations), 1.0) << id;
    EXPECT_DOUBLE_EQ(ndtwScore(locations, locations, 3.0, DtwMethod::kFast),
                     1.0)
        << id;
    const std::vector<Vec3f> start{locations.front()};
    const double stay = ndtwScore(start, locations);
    EXPECT_GT(stay, 0.0);
    EXPECT_LT(stay, 1.0);
  }
}

}  // namespace
}  // namespace vln::rollout
