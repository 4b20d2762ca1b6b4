// Rolling resistance (material.rolling_friction, docs/model.md section 2) against the rigid-body
// results it must give: a bead rolling on the plate stops after 7 v0^2 / (10 mu_r g), a
// spinning bead's spin falls at the constant rate mu_r R* m g / I, and without it a bead rolls
// on for ever, as the paper's model has it.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "dembuf/core/simulation.h"
#include "dembuf/study/bed/bed.h"
#include "dembuf/study/impact/impact.h"

namespace dembuf::test {
namespace {

constexpr double kRadius = 2.25e-3;  // mean bead of the paper
constexpr double kDensity = 2650.0;
constexpr double kGravity = 9.81;

double BeadMass() {
  return kDensity * 4.0 / 3.0 * std::numbers::pi * std::pow(kRadius, 3);
}

// The scene's contact constants with rolling resistance mu_r, set through the scene field, in
// a container wide enough for the bead to roll in.
dem::WorldParams RollingWorld(double mu_r, double friction) {
  Scene scene;
  scene.material.rolling_friction = mu_r;
  scene.material.friction_bead_bead = friction;
  scene.material.friction_bead_wall = friction;
  scene.gravity_m_s2 = kGravity;
  dem::WorldParams p = BuildWorld(scene).params;
  p.container = {1.0, 2.0};
  return p;
}

// Hertz overlap under the weight m g for the stiffness constant Kn / sqrt(R*).
double RestingOverlap(const dem::PairParams& p, double r_star) {
  return std::pow(BeadMass() * kGravity / (p.kn_per_sqrt_r * std::sqrt(r_star)), 2.0 / 3.0);
}

// A bead resting on the plate (at its Hertz overlap, so that the plate carries its weight
// from the start), rolling along x at v0 without slipping.
dem::Simulation RollingOnThePlate(const dem::WorldParams& p, double v0) {
  const double overlap = RestingOverlap(p.sphere_wall, kRadius);
  dem::ParticleState beads;
  beads.Add(dem::Vec3(0.0, 0.0, kRadius - overlap), kRadius, kDensity);
  beads.velocity[0] = dem::Vec3(v0, 0.0, 0.0);
  // The contact point, a lever arm R - overlap/2 below the centre, stands still.
  beads.angular_velocity[0] = dem::Vec3(0.0, v0 / (kRadius - 0.5 * overlap), 0.0);
  return dem::Simulation(p, std::move(beads), std::nullopt);
}

TEST(RollingResistance, ABeadRollingOnThePlateStopsAtTheAnalyticDistance) {
  // Rolling without slipping against a torque mu_r R m g: m a = F and I a / R = -F R - mu_r R m g
  // give a = -mu_r g / (1 + I / (m R^2)) = -5/7 mu_r g, so the bead stops after
  // v0^2 / (2 |a|) = 7 v0^2 / (10 mu_r g) in v0 / |a|. It needs a friction force of 5/7 mu_r m g,
  // well below mu m g here, so it does not slip.
  const double mu_r = 0.05, v0 = 0.05;
  const dem::WorldParams p = RollingWorld(mu_r, 0.5);
  dem::Simulation sim = RollingOnThePlate(p, v0);
  const double deceleration = 5.0 / 7.0 * mu_r * kGravity;
  const double distance = v0 * v0 / (2.0 * deceleration);
  const double stop_time = v0 / deceleration;
  double speed_at_half = -1.0;
  while (sim.time_s() < 1.5 * stop_time) {
    sim.Step();
    if (speed_at_half < 0.0 && sim.time_s() >= 0.5 * stop_time)
      speed_at_half = sim.beads().velocity[0].x();
  }
  const dem::Vec3& x = sim.beads().position[0];
  std::printf("rolled %.4f mm (analytic %.4f mm), speed at half time %.5f m/s (analytic %.5f)\n",
              x.x() * 1e3, distance * 1e3, speed_at_half, 0.5 * v0);
  EXPECT_NEAR(x.x(), distance, 0.01 * distance);
  EXPECT_NEAR(speed_at_half, 0.5 * v0, 0.01 * v0);
  // It has stopped and stays stopped (the torque never turns it back).
  EXPECT_LT(sim.beads().velocity[0].norm(), 1e-4 * v0);
  EXPECT_LT(sim.beads().angular_velocity[0].norm() * kRadius, 1e-4 * v0);
  EXPECT_NEAR(x.y(), 0.0, 1e-12);
}

TEST(RollingResistance, WithoutItABeadRollsOn) {
  // The paper's model (mu_r = 0, the default): pure rolling dissipates nothing.
  EXPECT_EQ(Scene{}.material.rolling_friction, 0.0);
  const double v0 = 0.05, duration = 0.1;
  dem::Simulation sim = RollingOnThePlate(RollingWorld(0.0, 0.5), v0);
  while (sim.time_s() < duration) sim.Step();
  EXPECT_NEAR(sim.beads().velocity[0].x(), v0, 1e-3 * v0);
  EXPECT_NEAR(sim.beads().position[0].x(), v0 * sim.time_s(), 1e-3 * v0 * duration);
}

TEST(RollingResistance, ASpinningBeadOnAnotherStopsAtTheAnalyticTime) {
  // A bead resting on a bead held in place, spinning about a horizontal axis, without sliding
  // friction: only the bead-bead rolling torque mu_r R* m g (R* = R/2) acts, so the spin falls
  // linearly, w(t) = w0 - mu_r R* m g t / I, and stays at zero once there.
  const double mu_r = 0.05, w0 = 20.0;
  const dem::WorldParams p = RollingWorld(mu_r, 0.0);
  const double r_star = 0.5 * kRadius;
  const double overlap = RestingOverlap(p.sphere_pair, r_star);
  dem::ParticleState beads;
  beads.Add(dem::Vec3(0.0, 0.0, 0.1), kRadius, kDensity);
  beads.inv_mass[0] = 0.0;  // held
  beads.Add(dem::Vec3(0.0, 0.0, 0.1 + 2.0 * kRadius - overlap), kRadius, kDensity);
  beads.angular_velocity[1] = dem::Vec3(w0, 0.0, 0.0);
  dem::Simulation sim(p, std::move(beads), std::nullopt);
  const double inertia = 0.4 * BeadMass() * kRadius * kRadius;
  const double rate = mu_r * r_star * BeadMass() * kGravity / inertia;
  const double stop_time = w0 / rate;
  double spin_at_half = -1.0;
  while (sim.time_s() < 1.5 * stop_time) {
    sim.Step();
    if (spin_at_half < 0.0 && sim.time_s() >= 0.5 * stop_time)
      spin_at_half = sim.beads().angular_velocity[1].x();
  }
  std::printf("spin at half time %.4f rad/s (analytic %.4f), stop time %.4f s\n", spin_at_half,
              0.5 * w0, stop_time);
  EXPECT_NEAR(spin_at_half, 0.5 * w0, 0.01 * w0);
  EXPECT_LT(std::abs(sim.beads().angular_velocity[1].x()), 1e-6 * w0);
  // The held bead did not turn, and the top bead did not move sideways.
  EXPECT_EQ(sim.beads().angular_velocity[0].norm(), 0.0);
  EXPECT_NEAR(sim.beads().position[1].y(), 0.0, 1e-12);
}

TEST(RollingResistance, IsOutOfTheBedsCacheKey) {
  // Beds settle without it, so it leaves their hashes alone: a cached bed serves every mu_r.
  Scene with;
  with.material.rolling_friction = 0.1;
  EXPECT_EQ(BedHash(Scene{}), BedHash(with));
}

}  // namespace
}  // namespace dembuf::test
