// Hc found directly: the bed thickness from which the peak plate force P stays within a margin
// (10%) of its plateau, found by bisection instead of read off a fixed grid.
//
// The plateau is P at the deepest thickness of the range (mean over seeds); the threshold is
// (1 + margin) times it, which is lambda reaching 1 - (1 + margin)(1 - lambda_plateau). Like
// the grid rule, the deep end counts as a plateau only if P has levelled off: the first
// midpoint (the upper half's start) must be within the margin, else Hc is "not reached". The
// range's shallow end must lie above the threshold; then the bracket [low, high] is halved,
// each midpoint run for every seed, until it is narrower than the tolerance. Hc is where the
// straight line between the bracket's ends crosses the threshold. Its uncertainty combines the
// bracket's width with the seeds' scatter: the standard errors of the mean P at the bracket's
// ends and of the plateau, turned into thickness by the slope of P between the ends.
#pragma once

#include <functional>
#include <string>
#include <vector>

namespace dembuf {

struct HcSearchOptions {
  double low_m = 0.005;        ///< shallow end: P must be above the threshold here
  double high_m = 0.06;        ///< deep end: its P is the plateau
  double tolerance_m = 0.001;  ///< stop when the bracket is narrower
  double margin = 0.10;        ///< P within this fraction above the plateau counts as on it
  int max_steps = 12;          ///< bisection steps at most (the tolerance usually stops it first)
};

/// One thickness run: the peak force of each seed.
struct HcPoint {
  double h_m = 0.0;
  std::vector<double> p_N;
  double mean_N = 0.0;
  double sd_N = 0.0;  ///< NaN for one seed
};

struct HcSearchResult {
  double hc_m = 0.0;
  double hc_sd_m = 0.0;  ///< bracket and (with several seeds) seed scatter
  bool seed_scatter_included = false;
  double plateau_N = 0.0;
  double threshold_N = 0.0;
  double bracket_low_m = 0.0, bracket_high_m = 0.0;
  /// Whether P levels off in the range, as the grid rule asks (CriticalThickness): P
  /// at the upper half's start (the first midpoint) within the margin of the plateau either
  /// way. Where not, hc_m is where the search ended but no Hc to report.
  bool reached = false;
  /// How P changes across the upper half, as the grid rule's: 1 - P(upper half's start) /
  /// plateau, negative where P still falls (across the whole range when the shallow end is
  /// already on the plateau, or no midpoint was run).
  double upper_half_change = 0.0;
  /// "" when Hc was found; else why not ("P at the shallow end is already on the
  /// plateau", "Hc not reached in 0.5-1.2 cm (P still falls 45% over the upper half)", ...).
  std::string note;
  std::vector<HcPoint> points;  ///< in the order they were run
};

/// Peak forces of every seed at thickness h (m). Throws to stop the search.
using PeakForcesAt = std::function<std::vector<double>(double h_m)>;

/// Runs the search, calling `peak_forces_at` for the deep end, the shallow end, then each
/// midpoint. Throws std::invalid_argument for a range or options that make no search.
HcSearchResult FindCriticalThickness(const PeakForcesAt& peak_forces_at,
                                     const HcSearchOptions& options);

}  // namespace dembuf
