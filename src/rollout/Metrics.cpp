#include "rollout/Metrics.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "common/Check.h"

namespace vln::rollout {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// ---------------------------------------------------------------------------
// DTW cores, generic over the point type
// ---------------------------------------------------------------------------

double pointDistance(const Vec3d& a, const Vec3d& b) { return (b - a).norm(); }
double pointDistance(double a, double b) { return std::fabs(a - b); }

// Exact DTW as the dtw 1.4.0 package computes it. Without `wantPath` only two
// rows are kept; with it the full accumulated matrix is traced back, diagonal
// first on ties (the package's _traceback argmin order).
template <class P>
DtwResult exactDtw(std::span<const P> a, std::span<const P> b, bool wantPath,
                   const char* caller) {
  VLN_CHECK_ARG(!a.empty() && !b.empty(), caller,
                ": DTW needs two non-empty sequences, got lengths ", a.size(),
                " and ", b.size());
  const size_t n = a.size(), m = b.size();
  DtwResult result;
  if (!wantPath) {
    std::vector<double> prev(m + 1, kInf), curr(m + 1, kInf);
    prev[0] = 0.0;
    for (size_t i = 1; i <= n; ++i) {
      curr[0] = kInf;
      for (size_t j = 1; j <= m; ++j)
        curr[j] = pointDistance(a[i - 1], b[j - 1]) +
                  std::min({prev[j - 1], prev[j], curr[j - 1]});
      std::swap(prev, curr);
    }
    result.distance = prev[m];
    return result;
  }
  // D is (n+1) x (m+1) with an infinite border and D[0][0] = 0
  std::vector<double> d((n + 1) * (m + 1), kInf);
  auto at = [&](size_t i, size_t j) -> double& { return d[i * (m + 1) + j]; };
  at(0, 0) = 0.0;
  for (size_t i = 1; i <= n; ++i)
    for (size_t j = 1; j <= m; ++j)
      at(i, j) = pointDistance(a[i - 1], b[j - 1]) +
                 std::min({at(i - 1, j - 1), at(i - 1, j), at(i, j - 1)});
  result.distance = at(n, m);
  size_t i = n, j = m;
  result.path.emplace_back(static_cast<int>(i - 1), static_cast<int>(j - 1));
  while (i > 1 || j > 1) {
    const double diag = at(i - 1, j - 1), up = at(i - 1, j),
                 left = at(i, j - 1);
    if (diag <= up && diag <= left) {
      --i;
      --j;
    } else if (up <= left) {
      --i;
    } else {
      --j;
    }
    result.path.emplace_back(static_cast<int>(i - 1), static_cast<int>(j - 1));
  }
  std::reverse(result.path.begin(), result.path.end());
  return result;
}

// One cell of a FastDTW search window. The cost indices point into the cost
// vector, which has the window's indices shifted by one (cost[0] is the
// origin), and are -1 when the neighbour is outside the window; this is the
// fastdtw Cython module's WindowElement.
struct WindowCell {
  int x = 0, y = 0;
  int left = -1;    // (x, y - 1)
  int up = -1;      // (x - 1, y)
  int corner = -1;  // (x - 1, y - 1)
};

// The full window of the Cython dtw(): every cell, row by row.
std::vector<WindowCell> fullWindow(int lenX, int lenY) {
  std::vector<WindowCell> window;
  window.reserve(static_cast<size_t>(lenX) * lenY);
  int idx = 0;
  for (int x = 0; x < lenX; ++x) {
    for (int y = 0; y < lenY; ++y, ++idx) {
      WindowCell cell{x, y};
      if (x == 0 && y == 0) {
        cell.corner = 0;
      } else {
        cell.left = (y == 0 && x > 0) ? -1 : idx;
        cell.up = (x == 0 && y > 0) ? -1 : idx - lenY + 1;
        cell.corner = (cell.left == -1 || cell.up == -1) ? -1 : cell.up - 1;
      }
      window.push_back(cell);
    }
  }
  return window;
}

// DTW restricted to `window` (the Cython __dtw). The comparison order decides
// ties exactly as the package does: "up" only when strictly smallest, then
// "left" when strictly below the corner, otherwise the corner.
template <class P>
DtwResult windowedDtw(std::span<const P> x, std::span<const P> y,
                      const std::vector<WindowCell>& window) {
  const size_t costLen = window.size() + 1;
  std::vector<double> cost(costLen, 0.0);
  std::vector<int> previous(costLen, -1);
  for (size_t idx = 0; idx < window.size(); ++idx) {
    const WindowCell& cell = window[idx];
    const double dt = pointDistance(x[cell.x], y[cell.y]);
    const double dLeft = cell.left != -1 ? cost[cell.left] : kInf;
    const double dUp = cell.up != -1 ? cost[cell.up] : kInf;
    const double dCorner = cell.corner != -1 ? cost[cell.corner] : kInf;
    if (dUp < dLeft && dUp < dCorner) {
      cost[idx + 1] = dUp + dt;
      previous[idx + 1] = cell.up;
    } else if (dLeft < dCorner) {
      cost[idx + 1] = dLeft + dt;
      previous[idx + 1] = cell.left;
    } else {
      cost[idx + 1] = dCorner + dt;
      previous[idx + 1] = cell.corner;
    }
  }
  DtwResult result;
  result.distance = cost[costLen - 1];
  // walk back from the last cell to the origin sentinel
  for (int idx = static_cast<int>(costLen) - 1; idx != 0; idx = previous[idx]) {
    VLN_ASSERT(idx > 0);  // every window cell is reachable from the origin
    const WindowCell& cell = window[idx - 1];
    result.path.emplace_back(cell.x, cell.y);
  }
  std::reverse(result.path.begin(), result.path.end());
  return result;
}

// The Cython __expand_window: the projected low-resolution path widened by
// `radius` cells (per-row y bounds), then doubled to full resolution.
std::vector<WindowCell> expandWindow(
    const std::vector<std::pair<int, int>>& path, int lenX, int lenY,
    int radius) {
  struct LowHigh {
    int low = 0, high = 0;
  };
  // step 1: y range of the path in every low-resolution row
  const int maxX = path.back().first;
  const int maxY = path.back().second;
  std::vector<LowHigh> bounds1(maxX + 1);
  int previousY = 0;
  int currentX = -1;
  for (auto [px, py] : path) {
    if (px != currentX) {
      currentX = px;
      bounds1[px].low = py;
      if (currentX > 0) bounds1[px - 1].high = previousY;
    }
    previousY = py;
  }
  bounds1[maxX].high = previousY;

  // step 2: widen by radius along both axes
  std::vector<LowHigh> bounds2(maxX + radius + 1);
  for (int x = 0; x <= maxX; ++x) {
    bounds2[x].low = std::max(0, bounds1[std::max(0, x - radius)].low - radius);
    bounds2[x].high = std::min(
        maxY + radius, bounds1[std::min(maxX, x + radius)].high + radius);
  }
  for (int x = maxX + 1; x < maxX + radius + 1; ++x)
    bounds2[x] = bounds2[x - 1];

  // step 3: double the resolution (rows 2x and 2x+1 share a row's bounds)
  const int len3 = std::min(lenX, 2 * (maxX + radius + 1));
  std::vector<LowHigh> bounds3(len3);
  for (int x = 0; x < maxX + radius + 1; ++x) {
    for (int row : {2 * x, 2 * x + 1}) {
      if (row < lenX) {
        bounds3[row].low = 2 * bounds2[x].low;
        bounds3[row].high = std::min(lenY - 1, 2 * bounds2[x].high + 1);
      }
    }
  }

  // step 4: cells with neighbour cost indices. Like the package, a cell whose
  // column lies beyond the previous row's high bound gets no up and no
  // corner link, even where the corner cell exists.
  std::vector<WindowCell> window;
  int idx = 0;
  for (int x = 0; x < len3; ++x) {
    const int low = bounds3[x].low;
    const int high = bounds3[x].high;
    for (int y = low; y <= high; ++y, ++idx) {
      WindowCell cell{x, y};
      if (x == 0 && y == 0) {
        cell.corner = 0;
        window.push_back(cell);
        continue;
      }
      cell.left = (y == low) ? -1 : idx;
      if (x == 0 || y > bounds3[x - 1].high) {
        cell.up = -1;
      } else {
        cell.up = idx - (std::min(lenY - 1, bounds3[x - 1].high) - low + 1) + 1;
        if (cell.up == 0) cell.up = -1;
      }
      if (x == 0 || y < bounds3[x - 1].low + 1 || y > bounds3[x - 1].high)
        cell.corner = -1;
      else
        cell.corner = cell.up - 1;
      window.push_back(cell);
    }
  }
  return window;
}

// Pairwise means; an odd trailing element is dropped (fastdtw's
// __reduce_by_half).
template <class P>
std::vector<P> reduceByHalf(std::span<const P> x) {
  std::vector<P> out;
  out.reserve(x.size() / 2);
  for (size_t i = 0; i + 1 < x.size(); i += 2)
    out.push_back((x[i] + x[i + 1]) / 2.0);
  return out;
}

template <class P>
DtwResult fastDtwImpl(std::span<const P> x, std::span<const P> y, int radius) {
  const size_t minTimeSize = static_cast<size_t>(radius) + 2;
  if (x.size() < minTimeSize || y.size() < minTimeSize)
    return windowedDtw(
        x, y,
        fullWindow(static_cast<int>(x.size()), static_cast<int>(y.size())));
  const std::vector<P> xs = reduceByHalf(x);
  const std::vector<P> ys = reduceByHalf(y);
  const DtwResult coarse =
      fastDtwImpl(std::span<const P>(xs), std::span<const P>(ys), radius);
  return windowedDtw(x, y,
                     expandWindow(coarse.path, static_cast<int>(x.size()),
                                  static_cast<int>(y.size()), radius));
}

template <class P>
DtwResult fastDtwChecked(std::span<const P> x, std::span<const P> y,
                         int radius) {
  VLN_CHECK_ARG(!x.empty() && !y.empty(),
                "fastDtw(): DTW needs two non-empty sequences, got lengths ",
                x.size(), " and ", y.size());
  VLN_CHECK_ARG(radius >= 1, "fastDtw(): radius must be >= 1, got ", radius);
  return fastDtwImpl(x, y, radius);
}

std::vector<Vec3d> toDouble(std::span<const Vec3f> points) {
  std::vector<Vec3d> out;
  out.reserve(points.size());
  for (const auto& p : points) out.push_back(p.cast<double>());
  return out;
}

}  // namespace

// ---------------------------------------------------------------------------
// single metrics
// ---------------------------------------------------------------------------

double pathLength(std::span<const Vec3f> positions) {
  double total = 0.0;
  for (size_t i = 1; i < positions.size(); ++i)
    total +=
        (positions[i].cast<double>() - positions[i - 1].cast<double>()).norm();
  return total;
}

bool oracleSuccess(std::span<const Vec3f> positions, const Vec3f& goal,
                   const GeodesicFn& geodesic, double successDistance) {
  return oracleNavigationError(positions, goal, geodesic) < successDistance;
}

double oracleNavigationError(std::span<const Vec3f> positions,
                             const Vec3f& goal, const GeodesicFn& geodesic) {
  double nearest = std::numeric_limits<double>::infinity();
  // a repeated position has the same distance; skip the geodesic query
  for (size_t i = 0; i < positions.size(); ++i) {
    if (i > 0 && positions[i] == positions[i - 1]) continue;
    nearest = std::min(nearest, static_cast<double>(geodesic(positions[i], goal)));
  }
  return nearest;
}

double oracleSplScore(std::span<const Vec3f> positions, const Vec3f& goal,
                      const GeodesicFn& geodesic, double startDistance,
                      double successDistance) {
  double travelled = 0.0;
  for (size_t i = 1; i < positions.size(); ++i) {
    travelled +=
        (positions[i].cast<double>() - positions[i - 1].cast<double>()).norm();
    if (static_cast<double>(geodesic(positions[i], goal)) < successDistance)
      return splScore(/*success=*/true, startDistance, travelled);
  }
  return 0.0;
}

bool isSuccess(bool calledStop, double finalDistance, double successDistance) {
  return calledStop && finalDistance < successDistance;
}

double splScore(bool success, double startDistance, double pathLength) {
  if (!success) return 0.0;
  const double denominator = std::max(startDistance, pathLength);
  return denominator > 0.0 ? startDistance / denominator : 1.0;
}

std::vector<Vec3f> dedupConsecutive(std::span<const Vec3f> positions) {
  std::vector<Vec3f> out;
  out.reserve(positions.size());
  for (const auto& p : positions)
    if (out.empty() || !(p == out.back())) out.push_back(p);
  return out;
}

DtwResult dtw(std::span<const Vec3d> a, std::span<const Vec3d> b) {
  return exactDtw(a, b, /*wantPath=*/true, "dtw()");
}

DtwResult fastDtw(std::span<const Vec3d> a, std::span<const Vec3d> b,
                  int radius) {
  return fastDtwChecked(a, b, radius);
}

DtwResult dtw1d(std::span<const double> a, std::span<const double> b) {
  return exactDtw(a, b, /*wantPath=*/true, "dtw1d()");
}

DtwResult fastDtw1d(std::span<const double> a, std::span<const double> b,
                    int radius) {
  return fastDtwChecked(a, b, radius);
}

double ndtwScore(std::span<const Vec3f> positions,
                 std::span<const Vec3f> reference, double successDistance,
                 DtwMethod method, int fastdtwRadius) {
  VLN_CHECK_ARG(!positions.empty() && !reference.empty(),
                "ndtwScore(): needs agent positions and a reference path, got ",
                positions.size(), " positions and ", reference.size(),
                " reference points");
  VLN_CHECK_ARG(successDistance > 0.0,
                "ndtwScore(): success distance must be positive, got ",
                successDistance);
  const std::vector<Vec3d> agent = toDouble(dedupConsecutive(positions));
  const std::vector<Vec3d> gt = toDouble(reference);
  const double distance =
      method == DtwMethod::kExact
          ? exactDtw(std::span<const Vec3d>(agent), std::span<const Vec3d>(gt),
                     /*wantPath=*/false, "ndtwScore()")
                .distance
          : fastDtwChecked(std::span<const Vec3d>(agent),
                           std::span<const Vec3d>(gt), fastdtwRadius)
                .distance;
  return std::exp(-distance /
                  (static_cast<double>(reference.size()) * successDistance));
}

EpisodeMetrics computeEpisodeMetrics(const EpisodeRecord& record,
                                     const GeodesicFn& geodesic,
                                     const MetricsOptions& options) {
  const std::string where =
      strCat("computeEpisodeMetrics(): episode '", record.episode_id, "'");

  // consistency of the record
  VLN_CHECK_ARG(!record.positions.empty(), where,
                ": field 'positions' is empty");
  VLN_CHECK_ARG(record.steps_taken >= 0 &&
                    record.positions.size() ==
                        static_cast<size_t>(record.steps_taken) + 1,
                where, ": field 'positions' must hold steps_taken + 1 = ",
                record.steps_taken + 1, " entries, got ",
                record.positions.size());
  VLN_CHECK_ARG(record.headings.empty() ||
                    record.headings.size() == record.positions.size(),
                where, ": field 'headings' must be empty or match positions (",
                record.positions.size(), "), got ", record.headings.size());
  VLN_CHECK_ARG(record.pitches.empty() ||
                    record.pitches.size() == record.positions.size(),
                where, ": field 'pitches' must be empty or match positions (",
                record.positions.size(), "), got ", record.pitches.size());
  VLN_CHECK_ARG(
      record.actions.empty() ||
          record.actions.size() == static_cast<size_t>(record.steps_taken),
      where, ": field 'actions' must be empty or hold steps_taken = ",
      record.steps_taken, " entries, got ", record.actions.size());
  // STOP is an action: it is the last one exactly when called_stop
  VLN_CHECK_ARG(!record.called_stop || record.steps_taken > 0, where,
                ": called_stop is true but no action was taken");
  VLN_CHECK_ARG(record.actions.empty() ||
                    (record.actions.back() == 0) == record.called_stop,
                where, ": called_stop is ", record.called_stop,
                " but the last action is ", record.actions.back());
  VLN_CHECK_ARG(!record.reference_path.empty(), where,
                ": field 'reference_path' is empty");
  VLN_CHECK_ARG(
      std::isfinite(record.start_distance) && record.start_distance >= 0, where,
      ": field 'start_distance' must be finite and >= 0, got ",
      record.start_distance);
  VLN_CHECK_ARG(options.success_distance > 0.0, where,
                ": success_distance must be positive, got ",
                options.success_distance);

  EpisodeMetrics m;
  m.distance_to_goal = geodesic(record.positions.back(), record.goal);
  VLN_CHECK_ARG(std::isfinite(m.distance_to_goal), where,
                ": geodesic distance from the final position to the goal is "
                "not finite, got ",
                m.distance_to_goal);
  m.path_length = pathLength(record.positions);
  const bool success = isSuccess(record.called_stop, m.distance_to_goal,
                                 options.success_distance);
  m.success = success ? 1.0 : 0.0;
  m.spl = splScore(success, record.start_distance, m.path_length);
  m.oracle_navigation_error =
      oracleNavigationError(record.positions, record.goal, geodesic);
  m.oracle_success =
      m.oracle_navigation_error < options.success_distance ? 1.0 : 0.0;
  m.oracle_spl = oracleSplScore(record.positions, record.goal, geodesic,
                                record.start_distance, options.success_distance);
  m.ndtw =
      ndtwScore(record.positions, record.reference_path,
                options.success_distance, options.dtw, options.fastdtw_radius);
  m.sdtw = m.success * m.ndtw;
  m.steps_taken = record.steps_taken;
  return m;
}

// ---------------------------------------------------------------------------
// aggregation
// ---------------------------------------------------------------------------

SplitStats aggregate(std::span<const EpisodeMetrics> episodes) {
  return averageMetrics<SplitStats>(episodes, kMetricFields, "aggregate()");
}

}  // namespace vln::rollout
