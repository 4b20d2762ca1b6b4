// The damping calibration: e(g) of the dimensionless Kuwabara-Kono collision and its inverse.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "dembuf/core/damping.h"

namespace dembuf {
namespace {

TEST(DampingNumber, NoDampingIsElastic) {
  EXPECT_NEAR(dem::RestitutionOfDampingNumber(0.0), 1.0, 1e-6);
}

TEST(DampingNumber, RestitutionFallsMonotonicallyWithDamping) {
  double previous = 1.0;
  for (double g = 0.05; g < 5.0; g *= 1.5) {
    const double e = dem::RestitutionOfDampingNumber(g);
    EXPECT_LT(e, previous) << "g = " << g;
    EXPECT_GT(e, 0.0);
    previous = e;
  }
}

TEST(DampingNumber, InverseRecoversTheRestitution) {
  for (double e : {0.05, 0.3, 0.5, 0.8, 0.95, 0.999}) {
    const double g = dem::DampingNumberForRestitution(e);
    EXPECT_NEAR(dem::RestitutionOfDampingNumber(g), e, 1e-9) << "e = " << e;
  }
  EXPECT_EQ(dem::DampingNumberForRestitution(1.0), 0.0);
  EXPECT_THROW(dem::DampingNumberForRestitution(0.0), std::invalid_argument);
  EXPECT_THROW(dem::DampingNumberForRestitution(1.5), std::invalid_argument);
}

TEST(DampingNumber, RememberedRestitutionIsReturnedForItsDampingNumber) {
  // The values are remembered by g: asked again, in another order, each g gets its own value
  // back, and the values still fall with g (a mix-up of keys would break either).
  std::vector<double> gs, first;
  for (double g = 0.031; g < 3.0; g *= 1.7) {
    gs.push_back(g);
    first.push_back(dem::RestitutionOfDampingNumber(g));
  }
  for (std::size_t k = gs.size(); k-- > 0;) {
    EXPECT_EQ(dem::RestitutionOfDampingNumber(gs[k]), first[k]) << "g = " << gs[k];
    if (k > 0) {
      EXPECT_LT(first[k], first[k - 1]);
    }
  }
}

TEST(DampingNumber, WeakDampingLimitIsLinearInG) {
  // For g -> 0 the dissipated fraction grows linearly: 1 - e = c g. The slope must be the
  // same at two small g (a check of the integrator near the elastic limit).
  const double s1 = (1.0 - dem::RestitutionOfDampingNumber(1e-3)) / 1e-3;
  const double s2 = (1.0 - dem::RestitutionOfDampingNumber(2e-3)) / 2e-3;
  EXPECT_NEAR(s1 / s2, 1.0, 2e-3);
}

TEST(Calibration, RestitutionDependsOnlyOnTheDampingNumber) {
  // g = A (Kn/m*)^(2/5) v^(1/5): scale Kn/m* by 32 and v by 1/1024, g stays the same.
  const dem::DampingCalibration cal = dem::CalibrateDamping(0.8, 1.0, 1.2e8, 6.3e-5);
  EXPECT_NEAR(cal.restitution_at_ref, 0.8, 1e-9);
  const double e_other =
      dem::RestitutionAtSpeed(cal.damping_A_s, 32.0 * 1.2e8, 6.3e-5, 1.0 / 1024.0);
  EXPECT_NEAR(e_other, 0.8, 1e-9);
}

TEST(Calibration, ReportsTheSpeedDependence) {
  const dem::DampingCalibration cal = dem::CalibrateDamping(0.8, 1.0, 1.2e8, 6.3e-5);
  ASSERT_EQ(cal.restitution_curve.size(), 5u);
  for (std::size_t k = 1; k < cal.restitution_curve.size(); ++k)
    EXPECT_LT(cal.restitution_curve[k].restitution, cal.restitution_curve[k - 1].restitution);
}

}  // namespace
}  // namespace dembuf
