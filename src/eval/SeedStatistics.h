#pragma once
// Statistics over training seeds for the tables and the paper's findings:
// the mean of a metric over seeds with its two-sided Student t confidence
// interval (n - 1 degrees of freedom), and the verdict on a paired
// difference between two rows (same seeds in both).
//
// Seeds are few (3 by default), so the interval uses Student's t, not the
// normal approximation: with 3 seeds the 95% half-width is 4.30 standard
// errors, not 1.96.

#include <span>
#include <string_view>

namespace vln::eval {

/// Confidence level of every interval the tables and the findings print.
inline constexpr double kConfidenceLevel = 0.95;

/// The p-quantile of Student's t distribution with `dof` degrees of
/// freedom: the t with P(T <= t) = p. Exact up to floating-point rounding
/// for every integer dof (the finite series of Abramowitz & Stegun 26.7.3
/// and 26.7.4, inverted by bisection). Throws std::invalid_argument unless
/// 0 < p < 1 and dof >= 1.
double studentTQuantile(double p, int dof);

/// A mean over n values and the half-width of its two-sided confidence
/// interval: the interval is [mean - half_width, mean + half_width].
struct Interval {
  double mean = 0.0;
  /// t_{(1 + level) / 2, n - 1} * s / sqrt(n), s the sample standard
  /// deviation; +infinity when n == 1 (one value says nothing about the
  /// spread, so nothing is excluded).
  double half_width = 0.0;
  int n = 0;
  double low() const { return mean - half_width; }
  double high() const { return mean + half_width; }
};

/// Mean and `level` interval of `values`; throws std::invalid_argument when
/// `values` is empty or `level` is not in (0, 1). A non-finite value makes
/// the mean and the half-width non-finite.
Interval meanInterval(std::span<const double> values,
                      double level = kConfidenceLevel);

/// Verdict on a claim that one row is better than another, from the
/// interval of the paired improvement (positive = the claimed direction).
enum class Verdict {
  kHolds,        ///< the interval excludes 0 on the claimed side
  kDoesNotHold,  ///< the interval excludes 0 on the opposite side
  kCannotTell,   ///< the interval contains 0 (or is not finite)
};

/// Judges `improvement` (Verdict's definitions); an interval touching 0
/// counts as containing it.
Verdict judgeImprovement(const Interval& improvement);

/// "holds", "does not hold" or "cannot tell".
std::string_view verdictName(Verdict verdict);

}  // namespace vln::eval
