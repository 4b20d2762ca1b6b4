// The Pa/Pb peak detector on synthetic signals with known answers.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "dembuf/engine/peaks.h"

namespace dembuf {
namespace {

double Bump(double t, double centre, double width, double height) {
  const double x = (t - centre) / width;
  return height * std::exp(-x * x);
}

// A projectile arriving at 5 m/s at t = 0 and slowing linearly to rest at t_stop.
ImpactSeries Series(double t_end, const std::function<double(double)>& force, double t_stop) {
  ImpactSeries s;
  for (double t = 0.0; t <= t_end; t += 2e-6) {
    s.t_s.push_back(t);
    s.plate_force_N.push_back(force(t));
    const double speed = t < t_stop ? 5.0 * (1.0 - t / t_stop) : 0.0;
    s.projectile_speed_m_s.push_back(speed);
    s.projectile_z_m.push_back(0.1 - 5.0 * t + 2.5 * t * t / t_stop);
  }
  return s;
}

TEST(Peaks, SingleWavePeakIsPb) {
  // A thick bed: one early peak while the projectile is still fast, no push peak.
  const auto s = Series(
      0.01, [](double t) { return 30.0 + Bump(t, 0.0012, 0.0003, 2000.0); }, 0.008);
  const PeakAnalysis a = AnalyzePeaks(s, 30.0, 5.0);
  ASSERT_EQ(a.peaks.size(), 1u);
  EXPECT_TRUE(a.has_pb);
  EXPECT_FALSE(a.has_pa);
  EXPECT_NEAR(a.pb.force_N, 2030.0, 1.0);
  EXPECT_NEAR(a.pb.time_s, 0.0012, 4e-6);
  EXPECT_DOUBLE_EQ(a.p_N, a.pb.force_N);
  EXPECT_EQ(a.ds_m, 0.0);
  // Load duration: the bump exceeds 5% of its height for 2 w sqrt(ln 20) = 1.04 ms.
  EXPECT_NEAR(a.load_duration_s, 2 * 0.0003 * std::sqrt(std::log(20.0)), 2e-5);
}

TEST(Peaks, WaveThenPushGivesPbAndPaWithTravelAndDelay) {
  // A thin bed: a small wave peak, then a large push peak when the projectile has slowed.
  const double t_stop = 0.004;
  const auto s = Series(
      0.008,
      [](double t) { return Bump(t, 0.0003, 0.0001, 800.0) + Bump(t, 0.0032, 0.0004, 6000.0); },
      t_stop);
  const PeakAnalysis a = AnalyzePeaks(s, 0.0, 5.0);
  ASSERT_TRUE(a.has_pa);
  ASSERT_TRUE(a.has_pb);
  EXPECT_NEAR(a.pb.force_N, 800.0, 5.0);
  EXPECT_NEAR(a.pa.force_N, 6000.0, 5.0);
  EXPECT_NEAR(a.dt_peaks_s, 0.0029, 1e-5);
  const auto z = [&](double t) { return 0.1 - 5.0 * t + 2.5 * t * t / t_stop; };
  EXPECT_NEAR(a.ds_m, z(0.0003) - z(0.0032), 1e-4);
  EXPECT_DOUBLE_EQ(a.p_N, a.pa.force_N);
}

TEST(Peaks, NoiseDoesNotMakePeaks) {
  // Contact-scale noise of 5% on one peak: still one peak, at the right place.
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(0.0, 50.0);
  const auto s = Series(
      0.01, [&](double t) { return Bump(t, 0.002, 0.0004, 1000.0) + noise(rng); }, 0.003);
  const PeakAnalysis a = AnalyzePeaks(s, 0.0, 5.0);
  ASSERT_EQ(a.peaks.size(), 1u);
  EXPECT_NEAR(a.peaks[0].time_s, 0.002, 1e-4);
  EXPECT_NEAR(a.p_N, 1000.0, 200.0);  // the raw maximum includes the noise on top
}

TEST(Peaks, RepeatedPlateHitsGiveSeveralPushPeaksAndPaIsTheLargest) {
  // Three hits of the plate after the projectile has slowed, decreasing.
  const auto s = Series(
      0.01,
      [](double t) {
        return Bump(t, 0.003, 0.0002, 5000.0) + Bump(t, 0.005, 0.0002, 3000.0) +
               Bump(t, 0.007, 0.0002, 1500.0);
      },
      0.0025);
  const PeakAnalysis a = AnalyzePeaks(s, 0.0, 5.0);
  ASSERT_EQ(a.peaks.size(), 3u);
  for (const auto& p : a.peaks) EXPECT_TRUE(p.is_push);
  EXPECT_FALSE(a.has_pb);
  EXPECT_NEAR(a.pa.force_N, 5000.0, 5.0);
  EXPECT_NEAR(a.pa.time_s, 0.003, 4e-6);
}

TEST(Peaks, BarePlateImpactIsOnePushPeak) {
  // The projectile stops at maximum compression: its speed is zero at the peak.
  ImpactSeries s;
  const double tc = 4.5e-4;
  for (double t = 0.0; t <= tc; t += 1.5e-6) {
    s.t_s.push_back(t);
    s.plate_force_N.push_back(13000.0 * std::pow(std::sin(M_PI * t / tc), 1.5));
    s.projectile_speed_m_s.push_back(5.5 * std::abs(std::cos(M_PI * t / tc)));
    s.projectile_z_m.push_back(0.025);
  }
  const PeakAnalysis a = AnalyzePeaks(s, 0.0, 5.5);
  ASSERT_EQ(a.peaks.size(), 1u);
  EXPECT_TRUE(a.has_pa);
  EXPECT_NEAR(a.pa.time_s, tc / 2, 2e-6);
}

}  // namespace
}  // namespace dembuf
