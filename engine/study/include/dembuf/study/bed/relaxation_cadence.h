// How often a bed's relaxation looks at its bed, in steps (engine/study/src/bed/bed.cpp).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>

namespace dembuf {

/// The whole bed's rest is judged every this many steps of the scene's own step.
inline constexpr std::int64_t kRestCheckSteps = 200;
/// A local-settling region's energy and moving beads are counted every this many steps.
inline constexpr std::int64_t kRegionCheckSteps = 50;
/// A region whose kinetic energy has not halved in this many steps is stalled: its beads are
/// stopped. Without rolling or twisting resistance a bead held by two contacts can spin about
/// the axis through them for ever, and a small region around it never ends. (In the
/// three-seed E2 sweep it stopped regions in 12 of 51 beds, whose C0 moved by 2e-4 at most:
/// docs/accuracy-cost.md.)
inline constexpr std::int64_t kStallSteps = 20000;
static_assert(kStallSteps % kRegionCheckSteps == 0, "a stall is judged at a region check");

/// The counts above, in steps of a relaxation. The cut bed's relaxation with a longer step
/// (bed.cut_alpha) looks as often in simulated time, so that its stages end at the same
/// moments of the bed's motion and not `step_scale` times later: each check is a chance to
/// pass, and the bed's spring-back taps its top beads denser for as long as it lasts
/// (docs/accuracy-cost.md). Every count is at least 1 step, so above a scale of 50 the
/// region checks, and above 200 the rest checks, come less often in time.
struct Cadence {
  std::int64_t rest_check = kRestCheckSteps;
  std::int64_t region_check = kRegionCheckSteps;
  std::int64_t stall = kStallSteps;  ///< a multiple of region_check

  /// `step_scale`: the relaxation's step over the scene's (at least 1).
  static Cadence ForStepScale(double step_scale) {
    auto scaled = [&](double steps) {
      return std::max<std::int64_t>(1, std::llround(steps / step_scale));
    };
    Cadence c;
    c.rest_check = scaled(kRestCheckSteps);
    c.region_check = scaled(kRegionCheckSteps);
    c.stall = c.region_check *
              std::max<std::int64_t>(1, std::llround(static_cast<double>(scaled(kStallSteps)) /
                                                     static_cast<double>(c.region_check)));
    return c;
  }
};

}  // namespace dembuf
