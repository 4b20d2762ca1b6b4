// The Pa/Pb peak detector on synthetic signals with known answers.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "dembuf/study/files/run_output.h"
#include "dembuf/study/impact/impact.h"
#include "dembuf/study/impact/peaks.h"

namespace dembuf {
namespace {

double Bump(double t, double centre, double width, double height) {
  const double x = (t - centre) / width;
  return height * std::exp(-x * x);
}

// A 5 cm bed (H = 5 cm) struck at t = 0 by a projectile of radius 2.5 cm arriving at 5 m/s
// and slowing uniformly to rest at t_stop: its lowest point descends from the surface by
// 2.5 t_stop m (5 mm per ms of t_stop).
constexpr double kBed = 0.05, kRadius = 0.025;
double Bottom(double t, double t_stop) {
  const double tt = std::min(t, t_stop);
  return kBed - 5.0 * tt + 2.5 * tt * tt / t_stop;
}
ImpactSeries Series(double t_end, const std::function<double(double)>& force, double t_stop) {
  ImpactSeries s;
  for (double t = 0.0; t <= t_end; t += 2e-6) {
    s.t_s.push_back(t);
    s.plate_force_N.push_back(force(t));
    s.projectile_z_m.push_back(Bottom(t, t_stop) + kRadius);
  }
  return s;
}
const PeakContext kContext{0.0, kBed, kRadius};

TEST(Peaks, SingleWavePeakIsPb) {
  // A thick bed: one early peak; the projectile stops 1 cm deep (t_stop = 4 ms).
  const auto s = Series(
      0.01, [](double t) { return 30.0 + Bump(t, 0.0012, 0.0003, 2000.0); }, 0.004);
  const PeakAnalysis a = AnalyzePeaks(s, {30.0, kBed, kRadius});
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
  // A small wave peak at the surface, then a large push peak at 12 ms, when the projectile's
  // lowest point is 1.25 cm above the plate (t_stop = 16 ms: it would stop 4 cm deep).
  const double t_stop = 0.016;
  const auto s = Series(
      0.014,
      [](double t) { return Bump(t, 0.0003, 0.0001, 800.0) + Bump(t, 0.012, 0.0004, 6000.0); },
      t_stop);
  const PeakAnalysis a = AnalyzePeaks(s, kContext);
  ASSERT_TRUE(a.has_pa);
  ASSERT_TRUE(a.has_pb);
  EXPECT_NEAR(a.pb.force_N, 800.0, 5.0);
  EXPECT_NEAR(a.pa.force_N, 6000.0, 5.0);
  EXPECT_NEAR(a.dt_peaks_s, 0.0117, 1e-5);
  EXPECT_NEAR(a.ds_m, Bottom(0.0003, t_stop) - Bottom(0.012, t_stop), 1e-4);
  EXPECT_DOUBLE_EQ(a.p_N, a.pa.force_N);
}

TEST(Peaks, NoiseDoesNotMakePeaks) {
  // Contact-scale noise of 5% on one peak: still one peak, at the right place.
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(0.0, 50.0);
  const auto s = Series(
      0.01, [&](double t) { return Bump(t, 0.002, 0.0004, 1000.0) + noise(rng); }, 0.003);
  const PeakAnalysis a = AnalyzePeaks(s, kContext);
  ASSERT_EQ(a.peaks.size(), 1u);
  EXPECT_NEAR(a.peaks[0].time_s, 0.002, 1e-4);
  EXPECT_NEAR(a.p_N, 1000.0, 200.0);  // the raw maximum includes the noise on top
}

TEST(Peaks, RepeatedPlateHitsGiveSeveralPushPeaksAndPaIsTheLargest) {
  // Three hits of the plate, decreasing, all with the projectile below half the bed (with
  // t_stop = 15 ms it is 2.3 cm above the plate at 7 ms and deeper after).
  const auto s = Series(
      0.012,
      [](double t) {
        return Bump(t, 0.007, 0.0002, 5000.0) + Bump(t, 0.009, 0.0002, 3000.0) +
               Bump(t, 0.011, 0.0002, 1500.0);
      },
      0.015);
  const PeakAnalysis a = AnalyzePeaks(s, kContext);
  ASSERT_EQ(a.peaks.size(), 3u);
  for (const auto& p : a.peaks) EXPECT_TRUE(p.is_push);
  EXPECT_FALSE(a.has_pb);
  EXPECT_NEAR(a.pa.force_N, 5000.0, 5.0);
  EXPECT_NEAR(a.pa.time_s, 0.007, 4e-6);
}

TEST(Peaks, InABedTwoBeadsDeepEveryPeakIsPa) {
  // H = 1 cm of 4.5 mm beads: a peak with the projectile's lowest point 6 mm above the plate
  // (above H/2, but within two bead diameters) is the projectile pressing on the plate.
  ImpactSeries s;
  for (double t = 0.0; t <= 0.002; t += 2e-6) {
    s.t_s.push_back(t);
    s.plate_force_N.push_back(Bump(t, 0.0006, 0.0002, 3000.0));
    s.projectile_z_m.push_back(0.025 + 0.010 - 4.0 * std::min(t, 0.001));
  }
  const PeakAnalysis thin = AnalyzePeaks(s, {0.0, 0.010, 0.025, 0.0045});
  ASSERT_EQ(thin.peaks.size(), 1u);
  EXPECT_TRUE(thin.has_pa);
  // Without the bead size, the same peak in the upper half of the bed is a wave peak.
  EXPECT_TRUE(AnalyzePeaks(s, {0.0, 0.010, 0.025, 0.0}).has_pb);
}

TEST(Peaks, BarePlateImpactIsOnePushPeak) {
  // No bed: the projectile's lowest point is at the plate.
  ImpactSeries s;
  const double tc = 4.5e-4;
  for (double t = 0.0; t <= tc; t += 1.5e-6) {
    s.t_s.push_back(t);
    s.plate_force_N.push_back(13000.0 * std::pow(std::sin(M_PI * t / tc), 1.5));
    s.projectile_z_m.push_back(0.025 - 0.0008 * std::sin(M_PI * t / tc));
  }
  const PeakAnalysis a = AnalyzePeaks(s, {0.0, 0.0, 0.025});
  ASSERT_EQ(a.peaks.size(), 1u);
  EXPECT_TRUE(a.has_pa);
  EXPECT_NEAR(a.pa.time_s, tc / 2, 2e-6);
}

// A thin bed hit twice: two push peaks. summary.json named both "Pa", and a reader took the
// second hump for the paper's Pa; now each peak is named once, the rest are bumps.
TEST(PeakNames, EachPeakIsNamedOnceAndTheOthersAreBumps) {
  ImpactSummary s;
  ForcePeak wave{900.0, 1e-4, 0.05, false}, first{3000.0, 3e-4, 0.02, true},
      second{1200.0, 6e-4, 0.021, true};
  s.peaks.peaks = {wave, first, second};
  s.peaks.has_pa = s.peaks.has_pb = true;
  s.peaks.pa = first;
  s.peaks.pb = wave;
  const nlohmann::json peaks = report::SummaryToJson(s, Scene{}, {})["peaks"];
  ASSERT_EQ(peaks.size(), 3u);
  EXPECT_EQ(peaks[0]["kind"], "Pb");
  EXPECT_EQ(peaks[1]["kind"], "Pa");
  EXPECT_EQ(peaks[2]["kind"], "bump");
  EXPECT_EQ(peaks[2]["push"], true);
}

// A run's own findings are kept with its results: the overlap note was printed on the
// terminal only, summary.json's warnings empty.
TEST(RunWarnings, ALargeOverlapIsKeptInTheSummaryAndItsLog) {
  ImpactSummary s;
  s.max_overlap_ratio = 0.25;
  const nlohmann::json summary = report::SummaryToJson(s, Scene{}, {});
  ASSERT_EQ(summary["warnings"].size(), 1u) << summary["warnings"];
  const std::string w = summary["warnings"][0];
  EXPECT_NE(w.find("max_overlap_ratio: the largest contact overlap reached 25% of a bead radius"),
            std::string::npos)
      << w;
  const std::string log = report::RunLogText(summary);
  EXPECT_NE(log.find("warning: " + w), std::string::npos) << log;
  EXPECT_NE(log.find("scene_sha256: "), std::string::npos) << log;
  s.max_overlap_ratio = 0.05;
  EXPECT_TRUE(report::SummaryToJson(s, Scene{}, {})["warnings"].empty());
  // ... and what an imported bed's file disagreed on.
  s.bed.warnings = {"bed.import: another density"};
  EXPECT_EQ(report::SummaryToJson(s, Scene{}, {})["warnings"],
            nlohmann::json({"bed.import: another density"}));
}

}  // namespace
}  // namespace dembuf
