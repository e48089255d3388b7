#include "eval/SeedStatistics.h"

#include <cmath>
#include <limits>
#include <numbers>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace vln::eval {
namespace {

using ::testing::HasSubstr;

// Quantiles of Student's t as printed in standard tables (six decimals),
// checked independently by integrating the density numerically.
TEST(SeedStatisticsTest, TQuantilesMatchTables) {
  struct Known {
    double p;
    int dof;
    double t;
  };
  const std::vector<Known> known = {
      {0.975, 1, 12.706205},  {0.975, 2, 4.302653}, {0.975, 3, 3.182446},
      {0.975, 4, 2.776445},   {0.975, 9, 2.262157}, {0.975, 30, 2.042272},
      {0.95, 5, 2.015048},    {0.995, 2, 9.924843}, {0.95, 2, 2.919986},
      {0.975, 1000, 1.962339}};
  for (const auto& k : known)
    EXPECT_NEAR(studentTQuantile(k.p, k.dof), k.t, 5e-7)
        << "p " << k.p << " dof " << k.dof;
}

// dof 1 (Cauchy) and dof 2 have closed forms: tan(pi (p - 1/2)) and
// (2p - 1) / sqrt(2 p (1 - p)).
TEST(SeedStatisticsTest, TQuantilesMatchClosedForms) {
  for (double p : {0.01, 0.2, 0.5, 0.6, 0.9, 0.975, 0.999}) {
    EXPECT_NEAR(studentTQuantile(p, 1), std::tan(std::numbers::pi * (p - 0.5)),
                1e-9)
        << p;
    EXPECT_NEAR(studentTQuantile(p, 2),
                (2 * p - 1) / std::sqrt(2 * p * (1 - p)), 1e-9)
        << p;
  }
}

TEST(SeedStatisticsTest, TQuantilesAreSymmetricAndApproachTheNormal) {
  EXPECT_DOUBLE_EQ(studentTQuantile(0.025, 4), -studentTQuantile(0.975, 4));
  EXPECT_NEAR(studentTQuantile(0.5, 7), 0.0, 1e-12);
  // z_{0.975} = 1.959964 is the limit; every finite dof lies above it
  EXPECT_GT(studentTQuantile(0.975, 5000), 1.959964);
  EXPECT_NEAR(studentTQuantile(0.975, 5000), 1.959964, 1e-3);
}

TEST(SeedStatisticsTest, TQuantileRejectsBadArguments) {
  EXPECT_THAT([] { studentTQuantile(0.0, 3); },
              ::testing::ThrowsMessage<std::invalid_argument>(
                  HasSubstr("probability must be in (0, 1), got 0")));
  EXPECT_THROW(studentTQuantile(1.0, 3), std::invalid_argument);
  EXPECT_THAT([] { studentTQuantile(0.9, 0); },
              ::testing::ThrowsMessage<std::invalid_argument>(
                  HasSubstr("degrees of freedom must be >= 1, got 0")));
}

// By hand: {0.1, 0.2, 0.3} has mean 0.2 and s = 0.1, so the 95% half-width
// is t_{0.975,2} 0.1 / sqrt(3) = 4.302653 * 0.0577350 = 0.248414.
TEST(SeedStatisticsTest, MeanIntervalByHand) {
  const std::vector<double> three = {0.1, 0.2, 0.3};
  const Interval a = meanInterval(three);
  EXPECT_EQ(a.n, 3);
  EXPECT_NEAR(a.mean, 0.2, 1e-12);
  EXPECT_NEAR(a.half_width, 0.248414, 1e-6);
  EXPECT_NEAR(a.low(), 0.2 - 0.248414, 1e-6);
  EXPECT_NEAR(a.high(), 0.2 + 0.248414, 1e-6);

  // {1..5}: s = sqrt(2.5), half-width 2.776445 * sqrt(2.5 / 5) = 1.963243
  const std::vector<double> five = {1, 2, 3, 4, 5};
  EXPECT_NEAR(meanInterval(five).half_width, 1.963243, 1e-6);

  // a 90% interval of {1, 2, 3}: t_{0.95,2} 1 / sqrt(3) = 1.685855
  const std::vector<double> ints = {1, 2, 3};
  EXPECT_NEAR(meanInterval(ints, 0.9).half_width, 2.919986 / std::sqrt(3.0),
              1e-6);

  // equal values: no spread, a zero-width interval
  const std::vector<double> same = {0.25, 0.25, 0.25};
  EXPECT_EQ(meanInterval(same).half_width, 0.0);
}

TEST(SeedStatisticsTest, OneValueHasAnUnboundedInterval) {
  const std::vector<double> one = {0.4};
  const Interval a = meanInterval(one);
  EXPECT_EQ(a.n, 1);
  EXPECT_EQ(a.mean, 0.4);
  EXPECT_TRUE(std::isinf(a.half_width));
  EXPECT_EQ(judgeImprovement(a), Verdict::kCannotTell);
}

TEST(SeedStatisticsTest, MeanIntervalRejectsBadArguments) {
  EXPECT_THAT([] { meanInterval({}); },
              ::testing::ThrowsMessage<std::invalid_argument>(
                  HasSubstr("meanInterval(): no values")));
  const std::vector<double> values = {1, 2};
  EXPECT_THROW(meanInterval(values, 1.0), std::invalid_argument);
}

// The three verdicts, and the borders between them.
TEST(SeedStatisticsTest, VerdictFromTheInterval) {
  const std::vector<double> better = {0.10, 0.11, 0.10};
  const std::vector<double> worse = {-0.05, -0.04, -0.06};
  const std::vector<double> mixed = {0.05, -0.02, 0.01};
  EXPECT_EQ(judgeImprovement(meanInterval(better)), Verdict::kHolds);
  EXPECT_EQ(judgeImprovement(meanInterval(worse)), Verdict::kDoesNotHold);
  EXPECT_EQ(judgeImprovement(meanInterval(mixed)), Verdict::kCannotTell);

  // an interval touching 0 contains it
  EXPECT_EQ(judgeImprovement({/*mean=*/0.1, /*half_width=*/0.1, /*n=*/3}),
            Verdict::kCannotTell);
  EXPECT_EQ(judgeImprovement({/*mean=*/0.1, /*half_width=*/0.0999, /*n=*/3}),
            Verdict::kHolds);
  // an infinite navigation error says nothing
  const double inf = std::numeric_limits<double>::infinity();
  const std::vector<double> infinite = {inf, 1.0};
  EXPECT_EQ(judgeImprovement(meanInterval(infinite)), Verdict::kCannotTell);

  EXPECT_EQ(verdictName(Verdict::kHolds), "holds");
  EXPECT_EQ(verdictName(Verdict::kDoesNotHold), "does not hold");
  EXPECT_EQ(verdictName(Verdict::kCannotTell), "cannot tell");
}

}  // namespace
}  // namespace vln::eval
