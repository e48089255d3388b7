#include "eval/SeedStatistics.h"

#include <cmath>
#include <limits>
#include <numbers>

#include "common/Check.h"

namespace vln::eval {
namespace {

// P(|T| <= t) for Student's t with `dof` degrees of freedom, written in
// theta = atan(t / sqrt(dof)), by the finite series of Abramowitz & Stegun
// 26.7.3 (odd dof) and 26.7.4 (even dof). Both series have positive terms
// only, so the sum loses no precision; each term is the previous one times
// cos^2(theta) (k - 1) / k.
double centralProbability(double theta, int dof) {
  const double s = std::sin(theta);
  const double c = std::cos(theta);
  const double c2 = c * c;
  // even: sin(theta) [1 + 1/2 c^2 + 1.3/(2.4) c^4 + ... (up to c^(dof-2))]
  if (dof % 2 == 0) {
    double term = 1.0, sum = 1.0;
    for (int k = 2; k <= dof - 2; k += 2) {
      term *= c2 * (k - 1) / k;
      sum += term;
    }
    return s * sum;
  }
  // odd: 2/pi [theta + sin cos (1 + 2/3 c^2 + 2.4/(3.5) c^4 + ...)], the
  // bracket absent for dof 1 (the Cauchy distribution)
  double sum = 0.0;
  if (dof > 1) {
    double term = 1.0;
    sum = 1.0;
    for (int k = 3; k <= dof - 2; k += 2) {
      term *= c2 * (k - 1) / k;
      sum += term;
    }
  }
  return 2.0 / std::numbers::pi * (theta + s * c * sum);
}

}  // namespace

double studentTQuantile(double p, int dof) {
  VLN_CHECK_ARG(p > 0.0 && p < 1.0,
                "studentTQuantile(): probability must be in (0, 1), got ", p);
  VLN_CHECK_ARG(dof >= 1,
                "studentTQuantile(): degrees of freedom must be >= 1, got ",
                dof);
  // the distribution is symmetric: solve for the upper half only
  if (p < 0.5) return -studentTQuantile(1.0 - p, dof);
  const double target = 2.0 * p - 1.0;
  // centralProbability() rises monotonically from 0 to 1 on [0, pi/2):
  // bisect until the bracket stops shrinking (about 60 halvings)
  double lo = 0.0, hi = std::numbers::pi / 2.0;
  while (true) {
    const double mid = 0.5 * (lo + hi);
    if (mid <= lo || mid >= hi) break;
    (centralProbability(mid, dof) < target ? lo : hi) = mid;
  }
  return std::sqrt(static_cast<double>(dof)) * std::tan(0.5 * (lo + hi));
}

Interval meanInterval(std::span<const double> values, double level) {
  VLN_CHECK_ARG(!values.empty(), "meanInterval(): no values");
  VLN_CHECK_ARG(level > 0.0 && level < 1.0,
                "meanInterval(): level must be in (0, 1), got ", level);
  Interval interval;
  interval.n = static_cast<int>(values.size());
  double sum = 0.0;
  for (double v : values) sum += v;
  interval.mean = sum / interval.n;
  if (interval.n == 1) {
    interval.half_width = std::numeric_limits<double>::infinity();
    return interval;
  }
  // sample standard deviation (n - 1 in the denominator)
  double squares = 0.0;
  for (double v : values) squares += (v - interval.mean) * (v - interval.mean);
  const double sd = std::sqrt(squares / (interval.n - 1));
  const double t = studentTQuantile(0.5 * (1.0 + level), interval.n - 1);
  interval.half_width = t * sd / std::sqrt(static_cast<double>(interval.n));
  return interval;
}

Verdict judgeImprovement(const Interval& improvement) {
  const double low = improvement.low();
  const double high = improvement.high();
  if (!std::isfinite(low) || !std::isfinite(high)) return Verdict::kCannotTell;
  if (low > 0.0) return Verdict::kHolds;
  if (high < 0.0) return Verdict::kDoesNotHold;
  return Verdict::kCannotTell;
}

std::string_view verdictName(Verdict verdict) {
  switch (verdict) {
    case Verdict::kHolds:
      return "holds";
    case Verdict::kDoesNotHold:
      return "does not hold";
    case Verdict::kCannotTell:
      return "cannot tell";
  }
  VLN_ASSERT(false);
  return "";
}

}  // namespace vln::eval
