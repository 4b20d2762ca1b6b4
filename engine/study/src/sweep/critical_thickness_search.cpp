#include "dembuf/study/sweep/critical_thickness_search.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>

namespace dembuf {

namespace {

HcPoint Evaluate(const PeakForcesAt& peak_forces_at, double h) {
  HcPoint point;
  point.h_m = h;
  point.p_N = peak_forces_at(h);
  if (point.p_N.empty()) throw std::runtime_error("no peak force at H = " + std::to_string(h));
  const double n = static_cast<double>(point.p_N.size());
  for (double p : point.p_N) point.mean_N += p / n;
  double var = 0.0;
  for (double p : point.p_N) var += (p - point.mean_N) * (p - point.mean_N);
  point.sd_N =
      point.p_N.size() > 1 ? std::sqrt(var / (n - 1)) : std::numeric_limits<double>::quiet_NaN();
  return point;
}

// The standard error of a point's mean P.
double StandardError(const HcPoint& p) {
  return p.sd_N / std::sqrt(static_cast<double>(p.p_N.size()));
}

}  // namespace

HcSearchResult FindCriticalThickness(const PeakForcesAt& peak_forces_at, const HcSearchOptions& o) {
  if (!(o.low_m >= 0.0 && o.low_m < o.high_m))
    throw std::invalid_argument("the range's shallow end must be below its deep end");
  if (!(o.tolerance_m > 0.0) || !(o.margin > 0.0) || o.max_steps < 1)
    throw std::invalid_argument("tolerance, margin and steps must be positive");
  HcSearchResult r;
  const HcPoint plateau = Evaluate(peak_forces_at, o.high_m);
  r.points.push_back(plateau);
  r.plateau_N = plateau.mean_N;
  r.threshold_N = (1.0 + o.margin) * plateau.mean_N;
  HcPoint low = Evaluate(peak_forces_at, o.low_m);
  r.points.push_back(low);
  HcPoint high = plateau;
  if (low.mean_N <= r.threshold_N) {
    r.reached = true;
    r.upper_half_change = 1.0 - low.mean_N / plateau.mean_N;
    r.hc_m = o.low_m;
    r.bracket_low_m = r.bracket_high_m = o.low_m;
    r.note =
        "P at the shallow end of the range is already within the margin of the plateau: "
        "Hc is at most there";
    return r;
  }
  for (int step = 0; step < o.max_steps && high.h_m - low.h_m > o.tolerance_m; ++step) {
    const HcPoint mid = Evaluate(peak_forces_at, 0.5 * (low.h_m + high.h_m));
    r.points.push_back(mid);
    (mid.mean_N > r.threshold_N ? low : high) = mid;
  }
  r.bracket_low_m = low.h_m;
  r.bracket_high_m = high.h_m;
  // Where the line between the bracket's ends crosses the threshold (low is above it, high
  // at or below).
  const double slope = (low.mean_N - high.mean_N) / (high.h_m - low.h_m);  // > 0
  r.hc_m = std::clamp(low.h_m + (low.mean_N - r.threshold_N) / slope, low.h_m, high.h_m);
  // A crossing anywhere in the bracket: the spread of a uniform distribution over it.
  const double bracket_sd = (high.h_m - low.h_m) / std::sqrt(12.0);
  r.seed_scatter_included =
      std::isfinite(low.sd_N) && std::isfinite(high.sd_N) && std::isfinite(plateau.sd_N);
  double scatter_sd = 0.0;
  if (r.seed_scatter_included) {
    // The error of mean P near the crossing, and of the threshold (from the plateau's mean).
    const double near = 0.5 * std::hypot(StandardError(low), StandardError(high));
    const double threshold = (1.0 + o.margin) * StandardError(plateau);
    scatter_sd = std::hypot(near, threshold) / slope;
  }
  r.hc_sd_m = std::hypot(bracket_sd, scatter_sd);
  if (high.h_m - low.h_m > o.tolerance_m)
    r.note = "stopped after " + std::to_string(o.max_steps) +
             " steps with the bracket still wider than the tolerance";
  // The first midpoint is the upper half's start: P levelled off only if it is on the plateau.
  const HcPoint& upper_start = r.points.size() > 2 ? r.points[2] : low;
  // As the grid rule: P may change by at most the margin either way (a P that rises again
  // towards the deep end has no plateau there either).
  r.upper_half_change = 1.0 - upper_start.mean_N / plateau.mean_N;
  r.reached = std::abs(r.upper_half_change) <= o.margin;
  if (!r.reached) {
    char note[160];
    std::snprintf(note, sizeof note,
                  "Hc not reached in %.3g-%.3g cm (P still %s %.0f%% over the upper half)",
                  100 * o.low_m, 100 * o.high_m, r.upper_half_change < 0 ? "falls" : "rises",
                  100 * std::abs(r.upper_half_change));
    r.note = note;
  }
  return r;
}

}  // namespace dembuf
