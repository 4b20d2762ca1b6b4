// The critical thickness Hc of a thickness sweep (sweep_report.h): reported only where P has
// levelled off in the range swept.
#include <gtest/gtest.h>

#include <cmath>
#include <utility>
#include <vector>

#include "dembuf/study/sweep/sweep_report.h"

namespace dembuf::report {
namespace {

// P(H) = plateau + a decaying excess, at thicknesses from `low` to `high` in `n` steps.
std::vector<std::pair<double, double>> Curve(double low, double high, int n, double decay_m) {
  std::vector<std::pair<double, double>> h_to_p;
  for (int k = 0; k < n; ++k) {
    const double h = low + (high - low) * k / (n - 1);
    h_to_p.push_back({h, 1000.0 + 9000.0 * std::exp(-h / decay_m)});
  }
  return h_to_p;
}

TEST(CriticalThickness, IsFoundWhereTheCurveLevelsOff) {
  // Excess 9000 exp(-H / 5 mm): within 10% of the plateau (1000 N) from H = 5 ln(90) = 22.5 mm.
  const nlohmann::json hc = CriticalThickness(Curve(0.0, 0.08, 17, 0.005));
  ASSERT_TRUE(hc["reached"].get<bool>()) << hc.dump();
  EXPECT_NEAR(hc["Hc_m"].get<double>(), 0.025, 1e-12);  // the first grid point past 22.5 mm
  EXPECT_NEAR(hc["plateau_P_N"].get<double>(), 1000.0, 5.0);
}

TEST(CriticalThickness, IsNotReportedWhereNothingLevelsOff) {
  // 0.5-1 cm of a curve that still falls steeply there: the old rule named Hc = 0.75 cm.
  const nlohmann::json hc = CriticalThickness(Curve(0.005, 0.01, 6, 0.005));
  EXPECT_FALSE(hc["reached"].get<bool>()) << hc.dump();
  EXPECT_TRUE(hc["Hc_m"].is_null());
  const std::string note = hc["note"].get<std::string>();
  EXPECT_NE(note.find("Hc not reached in 0.5-1 cm (P still falls"), std::string::npos) << note;
  EXPECT_LT(hc["upper_half_change"].get<double>(), -0.10);
}

TEST(CriticalThickness, TheUpperHalfIsOfTheRangeSwept) {
  // 4-8 cm of the levelled curve: flat throughout; Hc is the first point swept.
  const nlohmann::json hc = CriticalThickness(Curve(0.04, 0.08, 5, 0.005));
  ASSERT_TRUE(hc["reached"].get<bool>());
  EXPECT_DOUBLE_EQ(hc["Hc_m"].get<double>(), 0.04);
  EXPECT_EQ(hc["range_m"], nlohmann::json({0.04, 0.08}));
}

}  // namespace
}  // namespace dembuf::report
