// Damping of the beads' own motion (dem::BeadDamping), against what its equations give:
//   viscous, a free bead:        v(t) = v0 exp(-c t)               (and w(t) = w0 exp(-c t))
//   viscous, under gravity:      v(t) = -g/c (1 - exp(-c t))        (from rest)
//   local, a constant force F:   a = (F - alpha |F| sign(v)) / m   (g (1 -+ alpha) under gravity)
//   local, a free oscillation:   each half cycle the peak kinetic energy falls by
//                                (1 - alpha) / (1 + alpha), whatever the spring's shape: from a
//                                turning point to equilibrium the damping takes alpha times the
//                                potential energy released, and as much on the way out.
#include <gtest/gtest.h>

#include <cmath>
#include <optional>
#include <vector>

#include "dembuf/core/simulation.h"
#include "dembuf/study/scene/scene.h"
#include "engine/two_body.h"

namespace dembuf {
namespace {

constexpr double kRadius = 0.002, kDensity = 2500.0;

// One 4 mm glass bead in the middle of a large container, with the scene's contact constants.
dem::Simulation DampedBead(dem::WorldParams p, const dem::Vec3& x, const dem::Vec3& v,
                           const dem::Vec3& w = dem::Vec3::Zero()) {
  dem::ParticleState beads;
  beads.Add(x, kRadius, kDensity);
  beads.velocity[0] = v;
  beads.angular_velocity[0] = w;
  return dem::Simulation(p, std::move(beads), std::nullopt);
}

dem::WorldParams DampingWorld(double alpha, double rate, double gravity = 0.0) {
  Scene scene;  // friction on: beads turn, so that rotation is damped too
  dem::WorldParams p = test::IsolatedWorld(scene, 0.1);
  p.gravity_m_s2 = gravity;
  p.bead_damping = {alpha, rate};
  return p;
}

void StepUntil(dem::Simulation& sim, double t_s) {
  while (sim.time_s() < t_s * (1 - 1e-12)) sim.Step();
}

TEST(BeadDamping, ViscousDampingDecaysAFreeBeadsMotionExponentially) {
  const double rate = 200.0, v0 = 0.5, w0 = 30.0;
  dem::Simulation sim = DampedBead(DampingWorld(0.0, rate), dem::Vec3(0, 0, 1), dem::Vec3(v0, 0, 0),
                                   dem::Vec3(0, 0, w0));
  StepUntil(sim, 0.01);
  const double t = sim.time_s(), decay = std::exp(-rate * t);  // 0.135
  // The kick's damping term is explicit: (1 - rate dt) a step for exp(-rate dt), which errs by
  // (rate dt)^2 / 2 a step, rate t rate dt / 2 in all (1.6e-4 here); allowed twice that.
  const double tolerance = rate * t * rate * sim.params().dt_s;
  EXPECT_NEAR(sim.beads().velocity[0].x(), v0 * decay, tolerance * v0 * decay);
  EXPECT_NEAR(sim.beads().angular_velocity[0].z(), w0 * decay, tolerance * w0 * decay);
  EXPECT_EQ(sim.beads().velocity[0].y(), 0.0);
}

TEST(BeadDamping, ViscousDampingGivesTheTerminalSpeedUnderGravity) {
  const double rate = 100.0, g = 9.81;
  dem::Simulation sim =
      DampedBead(DampingWorld(0.0, rate, g), dem::Vec3(0, 0, 1.5), dem::Vec3::Zero());
  StepUntil(sim, 0.03);
  const double t = sim.time_s();
  const double expected = -g / rate * (1 - std::exp(-rate * t));  // 95% of g/c
  EXPECT_NEAR(sim.beads().velocity[0].z(), expected,
              rate * t * rate * sim.params().dt_s * std::abs(expected));
}

TEST(BeadDamping, LocalDampingTakesAlphaOfAConstantForce) {
  const double alpha = 0.6, g = 9.81, v0 = 1.0;
  // Falling: gravity and velocity alike, the damping takes alpha of the weight.
  dem::Simulation down =
      DampedBead(DampingWorld(alpha, 0.0, g), dem::Vec3(0, 0, 1.5), dem::Vec3(0, 0, -v0));
  StepUntil(down, 0.02);
  EXPECT_NEAR(down.beads().velocity[0].z(), -v0 - g * (1 - alpha) * down.time_s(), 1e-9);
  // Thrown upwards: against the motion it adds alpha of the weight, until the bead stops.
  dem::Simulation up =
      DampedBead(DampingWorld(alpha, 0.0, g), dem::Vec3(0, 0, 1.0), dem::Vec3(0, 0, v0));
  StepUntil(up, 0.04);  // it stops at v0 / (g (1 + alpha)) = 64 ms
  EXPECT_NEAR(up.beads().velocity[0].z(), v0 - g * (1 + alpha) * up.time_s(), 1e-9);
  // No force, no damping: a bead spinning freely is not slowed.
  dem::Simulation spin = DampedBead(DampingWorld(alpha, 0.0), dem::Vec3(0, 0, 1),
                                    dem::Vec3(0.1, 0, 0), dem::Vec3(0, 0, 30));
  StepUntil(spin, 0.01);
  EXPECT_EQ(spin.beads().velocity[0].x(), 0.1);
  EXPECT_EQ(spin.beads().angular_velocity[0].z(), 30.0);
}

// A bead on the plate, its contact undamped (restitution 1), set oscillating about its resting
// overlap under gravity: the peak speeds of successive half cycles.
std::vector<double> PeakSpeedsOnThePlate(double alpha) {
  Scene scene;
  scene.material.restitution = 1.0;
  dem::WorldParams p = test::IsolatedWorld(scene, 0.02);  // ~600 steps a period
  p.gravity_m_s2 = 9.81;
  p.bead_damping = {alpha, 0.0};
  // At its resting overlap (found by letting a slightly damped bead settle), then nudged.
  dem::WorldParams settle = p;
  settle.bead_damping = {0.5, 0.0};
  dem::Simulation rest = DampedBead(settle, dem::Vec3(0, 0, kRadius), dem::Vec3::Zero());
  StepUntil(rest, 0.005);
  dem::Simulation sim = DampedBead(p, rest.beads().position[0], dem::Vec3(0, 0, 1e-4));
  std::vector<double> peaks;
  double peak = 0.0, last_v = 1e-4;
  while (peaks.size() < 6 && sim.steps() < 200000) {
    sim.Step();
    const double v = sim.beads().velocity[0].z();
    peak = std::max(peak, std::abs(v));
    if ((v > 0.0) != (last_v > 0.0)) {  // a turning point: a half cycle ended
      peaks.push_back(peak);
      peak = 0.0;
    }
    last_v = v;
  }
  return peaks;
}

TEST(BeadDamping, LocalDampingOfAFreeOscillationLosesWhatItsEquationGives) {
  const double alpha = 0.1;
  const std::vector<double> peaks = PeakSpeedsOnThePlate(alpha);
  ASSERT_EQ(peaks.size(), 6u);
  const double expected = (1 - alpha) / (1 + alpha);  // 0.818
  for (std::size_t k = 2; k < peaks.size(); ++k) {    // (the first half cycle starts mid-way)
    const double ratio = peaks[k] * peaks[k] / (peaks[k - 1] * peaks[k - 1]);
    EXPECT_NEAR(ratio, expected, 0.01 * expected) << "half cycle " << k;
  }
  // Without damping the oscillation keeps its energy.
  const std::vector<double> free = PeakSpeedsOnThePlate(0.0);
  ASSERT_EQ(free.size(), 6u);
  EXPECT_NEAR(free[5] / free[2], 1.0, 1e-3);
}

}  // namespace
}  // namespace dembuf
