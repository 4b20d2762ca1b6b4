// Whole impact runs: the paper's no-bead impact, analytic free flight, the automatic end,
// observers, cancellation and the blow-up guard.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include "dembuf/study/impact/impact.h"
#include "dembuf/study/scene/errors.h"
#include "dembuf/study/scene/scene_fields.h"
#include "engine/temp_path.h"
#include "engine/two_body.h"

namespace dembuf {
namespace {

// E2 of the paper without beads: M = 0.3 kg, D = 5 cm, V0 = 5 m/s, H1 = 0.30 m, E = 5 GPa.
Scene PaperE2NoBeads() {
  Scene s;
  s.projectile.mass_kg = 0.3;
  s.projectile.speed_m_s = 5.0;
  s.projectile.height_m = 0.30;
  return s;
}

TEST(PaperCheck, NoBeadImpactPeakWithin2PercentOf13_46kN) {
  const Scene scene = PaperE2NoBeads();
  const ImpactSummary s = RunImpact(scene);
  EXPECT_NEAR(s.peak_plate_force_N / 13.46e3, 1.0, 0.02);
  EXPECT_EQ(s.beads, 0u);
  EXPECT_EQ(s.end_reason, "projectile rebounded clear");

  // Its time: free fall to the plate plus half the Hertz contact time at the impact speed.
  const double r = 0.025, g = 9.81;
  const double t_fall = FallTime(0.30, -5.0, r, g);
  const double v = 5.0 + g * t_fall;
  const World world = BuildWorld(scene);
  const double kn = world.params.sphere_wall.kn_per_sqrt_r * std::sqrt(r);
  const test::HertzImpact hertz(kn, 0.3, v);
  // Damping advances the peak slightly (by 0.5% of the contact time here); one time step is
  // 0.35% of it. 2% of the contact time covers both with margin and catches any real error.
  EXPECT_NEAR(s.peak_plate_force_time_s, t_fall + 0.5 * hertz.duration, 0.02 * hertz.duration);
  EXPECT_NEAR(s.impact_speed_m_s, v, 1e-3);
  std::printf("no-bead peak %.1f N at %.4f ms (free fall %.4f ms + half contact %.4f ms)\n",
              s.peak_plate_force_N, s.peak_plate_force_time_s * 1e3, t_fall * 1e3,
              0.5e3 * hertz.duration);
}

TEST(FreeFlight, FallTimeSolvesTheBallisticEquation) {
  const double t = FallTime(0.30, -5.0, 0.025, 9.81);
  EXPECT_NEAR(0.30 - 5.0 * t - 0.5 * 9.81 * t * t, 0.025, 1e-12);
  // Thrown upwards first: the later root.
  const double t_up = FallTime(1.0, 2.0, 0.5, 9.81);
  EXPECT_NEAR(1.0 + 2.0 * t_up - 0.5 * 9.81 * t_up * t_up, 0.5, 1e-12);
  EXPECT_GT(t_up, 2.0 / 9.81);
  EXPECT_EQ(FallTime(1.0, 0.0, 2.0, 9.81), 0.0);
  EXPECT_LT(FallTime(1.0, 1.0, 0.5, 0.0), 0.0);  // no gravity, moving up: never
}

TEST(FreeFlight, AnalyticFlightMatchesStepByStepIntegration) {
  // Integrate the same fall step by step with the engine and compare where the projectile is
  // when the analytic flight hands over: same height and speed within a step's worth.
  Scene scene = PaperE2NoBeads();
  scene.projectile.height_m = 0.10;  // keep the stepped run short
  World world = BuildWorld(scene);
  const double dt = world.params.dt_s;
  dem::Simulation stepped(world.params, {}, world.projectile);
  const double t_target = FallTime(0.10, -5.0, 0.03, 9.81);
  while (stepped.time_s() + 0.5 * dt < t_target) stepped.Step();
  const dem::RigidSphere& p = *stepped.projectile();
  const double t = stepped.time_s();
  EXPECT_NEAR(p.position.z(), 0.10 - 5.0 * t - 0.5 * 9.81 * t * t, 1e-9);
  EXPECT_NEAR(p.velocity.z(), -5.0 - 9.81 * t, 1e-9);
}

TEST(FreeFlight, IsNotSampled) {
  // A 10 m drop sampled every microsecond: the 1.4 s of free fall once wrote 1.4 million
  // samples of a resting plate (a 100 m drop at 0.15 us, 30 million, crashed the daemon). The
  // record now starts at the first output time after the analytic flight, just before contact.
  Scene scene = PaperE2NoBeads();
  scene.projectile.height_m = 10.0;
  scene.time.output_interval_s = 1e-6;
  std::vector<ImpactSample> samples;
  RunControl control;
  control.on_sample = [&](const ImpactSample& s) { samples.push_back(s); };
  const ImpactSummary summary = RunImpact(scene, control);
  ASSERT_FALSE(samples.empty());
  EXPECT_GT(summary.free_flight_s, 1.0);
  EXPECT_GE(samples.front().t_s, summary.free_flight_s);
  EXPECT_LT(samples.front().t_s, summary.free_flight_s + 1e-6 + summary.dt_s);
  EXPECT_LT(samples.front().t_s, summary.first_contact_time_s);
  // From there to the rebound, one sample a microsecond.
  EXPECT_LT(samples.size(), (summary.end_time_s - summary.free_flight_s) / 1e-6 + 2);
  EXPECT_NEAR(summary.impact_speed_m_s, std::sqrt(25.0 + 2.0 * 9.81 * (10.0 - 0.025)), 1e-3);
}

TEST(FreeFlight, AProjectileThatNeverArrivesIsRefused) {
  // No gravity and no speed: it would hang in the air for ever, waiting to touch the bed.
  Scene scene = PaperE2NoBeads();
  scene.gravity_m_s2 = 0.0;
  scene.projectile.speed_m_s = 0.0;
  try {
    ValidateScene(scene);
    FAIL() << "a projectile that never arrives was accepted";
  } catch (const SceneError& e) {
    EXPECT_EQ(e.field(), "projectile.speed_m_s");
    EXPECT_NE(std::string(e.what()).find("never reaches the bed"), std::string::npos) << e.what();
  }
  // A creeping one takes longer than any run may last (it ran out of memory in the daemon).
  scene.projectile.speed_m_s = 1e-300;
  try {
    ValidateScene(scene);
    FAIL() << "a flight of 3e299 s was accepted";
  } catch (const SceneError& e) {
    EXPECT_EQ(e.field(), "projectile.speed_m_s");
    EXPECT_NE(std::string(e.what()).find("after 2.75e+299 s; at most 1000 s (raise"),
              std::string::npos)
        << e.what();  // (it said "1000 s s")
  }
  // With a fixed end the run simply ends in flight, which is legal.
  scene.time.end_s = 0.01;
  EXPECT_NO_THROW(ValidateScene(scene));
  const ImpactSummary s = RunImpact(scene);
  EXPECT_EQ(s.end_reason, "reached time.end_s");
  EXPECT_LT(s.first_contact_time_s, 0.0);
  // And a scene without a projectile needs a fixed end, which submission checks too.
  scene.projectile.enabled = false;
  scene.time.end_s = 0.0;
  EXPECT_THROW(ValidateScene(scene), SceneError);
}

TEST(ImpactRun, SamplesAreOrderedAndOnTheOutputGrid) {
  Scene scene = PaperE2NoBeads();
  scene.time.output_interval_s = 1e-6;
  std::vector<ImpactSample> samples;
  RunControl control;
  control.on_sample = [&](const ImpactSample& s) { samples.push_back(s); };
  const ImpactSummary summary = RunImpact(scene, control);
  ASSERT_GT(samples.size(), 200u);
  double max_sampled = 0.0;
  for (std::size_t k = 1; k < samples.size(); ++k) {
    EXPECT_GT(samples[k].t_s, samples[k - 1].t_s);
    // Each sample is taken at the first step at or after its grid time.
    const double grid = std::round(samples[k].t_s / 1e-6) * 1e-6;
    EXPECT_LT(samples[k].t_s - grid, summary.dt_s + 1e-12);
    max_sampled = std::max(max_sampled, samples[k].plate_force_N);
  }
  // The summary's peak is over every step, so no sample exceeds it.
  EXPECT_LE(max_sampled, summary.peak_plate_force_N);
}

TEST(ImpactRun, FixedEndTimeIsHonoured) {
  Scene scene = PaperE2NoBeads();
  scene.time.end_s = 0.0524;
  const ImpactSummary s = RunImpact(scene);
  EXPECT_EQ(s.end_reason, "reached time.end_s");
  EXPECT_NEAR(s.end_time_s, 0.0524, s.dt_s);
}

TEST(ImpactRun, AReboundInsideTheCraterEndsTheRunWhenItCannotFallBackInTheWindow) {
  // A projectile that leaves the plate below the bed's surface (rising in its crater) has not
  // rebounded clear, but at the rebound speed (half the impact speed or more) it cannot come
  // back down within the 50 ms window: nothing is left to measure, and the run ends once the
  // plate force has stayed down for the peak analysis's smoothing width (50 us) instead of
  // when the projectile clears the surface. Pretend the surface is 1 cm above the plate.
  const Scene scene = PaperE2NoBeads();
  const ImpactSummary at_plate = RunImpact(scene);
  World world = BuildWorld(scene);
  world.bed_surface_m = 0.01;
  const ImpactSummary in_crater = RunImpact(std::move(world), scene);
  EXPECT_EQ(in_crater.end_reason,
            "projectile rebounded in its crater, too fast to fall back "
            "within time.impact_window_s");
  EXPECT_GE(in_crater.end_time_s, at_plate.end_time_s);
  EXPECT_LE(in_crater.end_time_s,
            at_plate.end_time_s + PeakOptions{}.smoothing_s + 1.5 * at_plate.dt_s);
  EXPECT_EQ(in_crater.peak_plate_force_N, at_plate.peak_plate_force_N);

  // Run on for 2 ms more: the peak analysis finds the same.
  Scene longer = scene;
  longer.time.end_s = in_crater.end_time_s + 2e-3;
  World again = BuildWorld(longer);
  again.bed_surface_m = 0.01;
  const ImpactSummary run_on = RunImpact(std::move(again), longer);
  EXPECT_EQ(run_on.peaks.p_N, in_crater.peaks.p_N);
  EXPECT_EQ(run_on.peaks.load_duration_s, in_crater.peaks.load_duration_s);
}

TEST(ImpactRun, ASlowReboundInsideTheBedFallsBackAndIsFollowed) {
  // Dropped 1 mm onto the plate at 5 cm/s, the projectile rebounds slowly enough to land again
  // within the window (2 v / g is 15-30 ms for a rebound of half to all of the impact speed).
  // Inside a pretended 1 cm bed it never clears the surface: the run must go on through the
  // second landing.
  Scene scene = PaperE2NoBeads();
  scene.projectile.speed_m_s = 0.05;
  scene.projectile.height_m = 0.026;
  World world = BuildWorld(scene);
  world.bed_surface_m = 0.01;
  const ImpactSummary s = RunImpact(std::move(world), scene);
  const double fall_back = 2.0 * 0.5 * s.impact_speed_m_s / 9.81;
  EXPECT_GT(s.end_time_s - s.first_contact_time_s, fall_back);
}

TEST(ImpactRun, CancelFlagStopsTheRun) {
  Scene scene = PaperE2NoBeads();
  std::atomic<bool> cancel{true};
  RunControl control;
  control.steering.cancel = &cancel;
  control.steering.progress_every_steps = 16;
  EXPECT_THROW(RunImpact(scene, control), Cancelled);
}

TEST(Stability, OversizedStepStopsWithAClearReason) {
  // A 50 m/s drop with the time step at the limit of eq. 6 and elastic, massive projectile on
  // bare plate: fine. The same with the step forced 40x larger must be refused mid-run, not
  // produce a garbage peak.
  Scene scene = PaperE2NoBeads();
  scene.projectile.speed_m_s = 50.0;
  World world = BuildWorld(scene);
  world.params.dt_s *= 400.0;
  try {
    RunImpact(std::move(world), scene);
    FAIL() << "expected a SimulationError";
  } catch (const dem::SimulationError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("the projectile"), std::string::npos) << what;
    EXPECT_NE(what.find("the plate"), std::string::npos) << what;
    EXPECT_NE(what.find("time.alpha"), std::string::npos) << what;
    EXPECT_GT(e.step(), 0);
  }
}

TEST(BedImport, TextBedIsReadRelaxedAndMeasured) {
  // A square monolayer of 2 mm beads resting on the plate of a 2 cm cylinder: every surface
  // cell holds a bead top at 4 mm, so the measured surface is 4 mm.
  const std::string path = test::TempPath("bed.txt");
  int count = 0;
  {
    std::ofstream out(path);
    out << "# x y z radius\n";
    for (int i = -4; i <= 4; ++i)
      for (int j = -4; j <= 4; ++j) {
        const double x = 0.0041 * i, y = 0.0041 * j;
        if (std::hypot(x, y) > 0.0175) continue;
        out << x << " " << y << " 0.002 0.002  # bead\n";
        ++count;
      }
  }
  Scene scene;
  scene.cylinder.radius_m = 0.02;
  scene.projectile.diameter_m = 0.01;
  scene.bed.import = path;
  const World world = BuildWorld(scene);
  ASSERT_EQ(world.beads.size(), static_cast<std::size_t>(count));
  EXPECT_NEAR(world.bed_surface_m, 0.004, 1e-5);  // relaxed: sunk by its Hertz overlap only
  EXPECT_DOUBLE_EQ(world.projectile->position.z(), world.bed_surface_m + scene.projectile.height_m);
  EXPECT_NEAR(world.bed.weight_N, count * world.beads.mass[0] * 9.81, 1e-9);
  EXPECT_NEAR(world.bed.rest_plate_force_N / world.bed.weight_N, 1.0, 0.01);

  std::ofstream(path) << "0 0 0.002 0.002\n0.2 0 0.01 0.002\n";
  try {
    BuildWorld(scene);
    FAIL();
  } catch (const SceneError& e) {
    EXPECT_EQ(e.field(), "bed.import");
    EXPECT_NE(std::string(e.what()).find(":2:"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace dembuf
