// The Hc bisection on synthetic P(H) curves with a known crossing.
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

#include "dembuf/study/sweep/critical_thickness_search.h"

namespace dembuf {
namespace {

// P(H) = 2 kN + 11 kN exp(-H / 6 mm): from 13 kN on the bare plate down to a plateau of 2 kN.
double SmoothP(double h) {
  return 2000.0 + 11000.0 * std::exp(-h / 0.006);
}

// The thickness where P = threshold on SmoothP.
double Crossing(double threshold) {
  return -0.006 * std::log((threshold - 2000.0) / 11000.0);
}

TEST(HcSearch, FindsAKnownCrossingWithinTheTolerance) {
  HcSearchOptions o;  // 5 mm to 6 cm, 1 mm, 10%
  int calls = 0;
  const HcSearchResult r = FindCriticalThickness(
      [&](double h) {
        ++calls;
        return std::vector<double>{SmoothP(h)};
      },
      o);
  EXPECT_TRUE(r.note.empty()) << r.note;
  EXPECT_DOUBLE_EQ(r.plateau_N, SmoothP(0.06));
  const double truth = Crossing(1.1 * SmoothP(0.06));  // 24.0 mm
  EXPECT_NEAR(truth, 0.0240, 0.0001);
  EXPECT_GE(truth, r.bracket_low_m);
  EXPECT_LE(truth, r.bracket_high_m);
  EXPECT_LE(r.bracket_high_m - r.bracket_low_m, o.tolerance_m);
  EXPECT_NEAR(r.hc_m, truth, 0.5 * o.tolerance_m);
  // One seed: only the bracket counts in the uncertainty.
  EXPECT_FALSE(r.seed_scatter_included);
  EXPECT_NEAR(r.hc_sd_m, (r.bracket_high_m - r.bracket_low_m) / std::sqrt(12.0), 1e-15);
  // The two ends, then log2(55 mm / 1 mm) -> 6 halvings.
  EXPECT_EQ(calls, 2 + 6);
  EXPECT_EQ(static_cast<int>(r.points.size()), calls);
}

// A range where P has not levelled off (5-12 mm of SmoothP: the deep end is no plateau): the
// search's Hc lies in the upper half, so P still falls by more than the margin there. No Hc
// is reported, as the grid rule says "Hc not reached" (it named 11.3 mm).
TEST(HcSearch, NoHcWherePStillFallsOverTheUpperHalf) {
  HcSearchOptions o;
  o.low_m = 0.005;
  o.high_m = 0.012;
  const HcSearchResult r =
      FindCriticalThickness([](double h) { return std::vector<double>{SmoothP(h)}; }, o);
  EXPECT_FALSE(r.reached);
  EXPECT_LT(r.upper_half_change, -0.10);  // signed as the grid rule's: P falls
  EXPECT_NEAR(r.upper_half_change, 1.0 - SmoothP(0.0085) / SmoothP(0.012), 1e-12);
  EXPECT_NE(r.note.find("Hc not reached in 0.5-1.2 cm (P still falls"), std::string::npos)
      << r.note;
  // A P that dips and rises again by 30% towards the deep end has no plateau there either.
  const HcSearchResult rising = FindCriticalThickness(
      [](double h) {
        return std::vector<double>{h < 0.0085 ? SmoothP(h) : 1000.0 * (1.0 + 100.0 * (h - 0.0085))};
      },
      o);
  EXPECT_FALSE(rising.reached);
  EXPECT_NE(rising.note.find("(P still rises"), std::string::npos) << rising.note;
  // The levelled curve of the first test reaches it.
  const HcSearchResult levelled =
      FindCriticalThickness([](double h) { return std::vector<double>{SmoothP(h)}; }, {});
  EXPECT_TRUE(levelled.reached);
  EXPECT_GE(levelled.upper_half_change, -0.10);
}

// Seeds scatter P by +-5%: Hc's uncertainty widens to cover it, and the truth is inside
// two of its standard deviations.
TEST(HcSearch, SeedScatterWidensTheUncertainty) {
  HcSearchOptions o;
  const std::vector<double> scatter = {0.95, 1.0, 1.05};
  const HcSearchResult r = FindCriticalThickness(
      [&](double h) {
        std::vector<double> p;
        for (double f : scatter) p.push_back(SmoothP(h) * f);
        return p;
      },
      o);
  EXPECT_TRUE(r.seed_scatter_included);
  const double bracket_only = (r.bracket_high_m - r.bracket_low_m) / std::sqrt(12.0);
  EXPECT_GT(r.hc_sd_m, 2 * bracket_only);
  const double truth = Crossing(1.1 * SmoothP(0.06));
  EXPECT_NEAR(r.hc_m, truth, 2 * r.hc_sd_m);
}

TEST(HcSearch, ARangeWithoutACrossingSaysSo) {
  HcSearchOptions o;
  o.low_m = 0.04;  // already on the plateau
  const HcSearchResult r =
      FindCriticalThickness([](double h) { return std::vector<double>{SmoothP(h)}; }, o);
  EXPECT_FALSE(r.note.empty());
  EXPECT_DOUBLE_EQ(r.hc_m, 0.04);
  o.low_m = 0.07;  // above the deep end
  EXPECT_THROW(FindCriticalThickness([](double h) { return std::vector<double>{SmoothP(h)}; }, o),
               std::invalid_argument);
}

}  // namespace
}  // namespace dembuf
