// Beads of several species: the pair of two different beads against Hertz with the pair's
// effective constants and the pair's calibrated restitution, and two species of one material
// against the world of one species, to the bit.
#include <gtest/gtest.h>

#include <numbers>
#include <random>

#include "dembuf/core/damping.h"
#include "dembuf/study/scene/species.h"
#include "engine/two_body.h"

namespace dembuf::test {
namespace {

constexpr double kMeanRadius = 2.25e-3;  // the mean bead of both species
constexpr double kFineStep = 0.005;

// Glass beads (species 1) with steel shot (species 2) mixed in, without friction.
Scene GlassWithSteel(double glass_e, double steel_e) {
  Scene scene;
  scene.material.restitution = glass_e;
  scene.material.friction_bead_bead = 0.0;
  scene.material.friction_bead_wall = 0.0;
  scene.species[0].restitution = steel_e;
  scene.species[0].friction_bead_bead = 0.0;
  scene.species[0].friction_bead_wall = 0.0;
  scene.layers[0].fraction2 = 0.3;
  return scene;
}

// A glass bead and a steel one approaching head-on at relative speed v, with zero momentum.
dem::Simulation GlassOnSteel(const dem::WorldParams& p, const Scene& scene, double v) {
  dem::ParticleState beads;
  const double gap = 1e-7;
  beads.Add(dem::Vec3(-kMeanRadius - gap, 0, 1), kMeanRadius, scene.material.density_kg_m3, 0);
  beads.Add(dem::Vec3(kMeanRadius + gap, 0, 1), kMeanRadius, scene.species[0].density_kg_m3, 1);
  const double m1 = beads.mass[0], m2 = beads.mass[1];
  beads.velocity[0] = dem::Vec3(v * m2 / (m1 + m2), 0, 0);
  beads.velocity[1] = dem::Vec3(-v * m1 / (m1 + m2), 0, 0);
  return dem::Simulation(p, std::move(beads), std::nullopt);
}

double Overlap(const dem::Simulation& s) {
  return 2.0 * kMeanRadius - (s.beads().position[0] - s.beads().position[1]).norm();
}
double Force(const dem::Simulation& s) {
  return s.beads().force[0].norm();
}

double ReducedMass(const Scene& scene) {
  const double volume = 4.0 / 3.0 * std::numbers::pi * std::pow(kMeanRadius, 3);
  const double m1 = scene.material.density_kg_m3 * volume;
  const double m2 = scene.species[0].density_kg_m3 * volume;
  return m1 * m2 / (m1 + m2);
}

// Hertz: 1/E* = (1 - nu1^2)/E1 + (1 - nu2^2)/E2 with the two materials, R* = R/2.
TEST(Species, AGlassBeadOnSteelMatchesHertzWithTheEffectiveConstants) {
  const Scene scene = GlassWithSteel(1.0, 1.0);
  const dem::WorldParams p = IsolatedWorld(scene, kFineStep);
  ASSERT_EQ(p.species.count, 2);
  const double e_star = 1.0 / ((1.0 - 0.22 * 0.22) / scene.material.youngs_modulus_Pa +
                               (1.0 - 0.30 * 0.30) / scene.species[0].youngs_modulus_Pa);
  const double kn = 4.0 / 3.0 * e_star * std::sqrt(0.5 * kMeanRadius);
  for (double v : {0.1, 1.0, 5.0}) {
    dem::Simulation sim = GlassOnSteel(p, scene, v);
    const ContactRecord rec = RecordContact(sim, Overlap, Force, 1'000'000);
    const HertzImpact hertz(kn, ReducedMass(scene), v);
    EXPECT_NEAR(rec.max_overlap / hertz.max_overlap, 1.0, 0.01) << "v = " << v;
    EXPECT_NEAR(rec.max_force / hertz.max_force, 1.0, 0.01) << "v = " << v;
    EXPECT_NEAR(rec.Duration() / hertz.duration, 1.0, 0.01) << "v = " << v;
  }
}

// The pair's restitution is the mean of the two species' (the rule), or the one given for the
// pair; each is met at the calibration speed.
TEST(Species, APairReboundsWithItsOwnRestitution) {
  for (const double given : {0.0, 0.4}) {
    Scene scene = GlassWithSteel(0.9, 0.5);
    scene.pairs.restitution_1_2 = given;
    const double expected = given > 0.0 ? given : 0.7;
    EXPECT_DOUBLE_EQ(PairRestitution(scene, 0, 1), expected);
    const dem::WorldParams p = IsolatedWorld(scene, kFineStep);
    dem::Simulation sim = GlassOnSteel(p, scene, 1.0);
    RecordContact(sim, Overlap, Force, 1'000'000);
    const double e = -(sim.beads().velocity[0].x() - sim.beads().velocity[1].x()) / 1.0;
    EXPECT_NEAR(e, expected, 0.005 * expected) << "pairs.restitution_1_2 = " << given;
  }
}

// The rules of the pairs, as docs/model.md states them.
TEST(Species, ThePairRulesAreTheMeanRestitutionAndTheSmallerFriction) {
  Scene scene;
  scene.material.restitution = 0.8;
  scene.material.friction_bead_bead = 0.5;
  scene.species[0].restitution = 0.4;
  scene.species[0].friction_bead_bead = 0.2;
  EXPECT_DOUBLE_EQ(PairRestitution(scene, 0, 1), 0.6);
  EXPECT_DOUBLE_EQ(PairFriction(scene, 0, 1), 0.2);
  EXPECT_DOUBLE_EQ(PairFriction(scene, 1, 1), 0.2);
  scene.pairs.friction_1_2 = 0.0;  // given: frictionless between the two
  EXPECT_DOUBLE_EQ(PairFriction(scene, 1, 0), 0.0);
}

// Beads on a jittered lattice in the container, a few layers above the plate, thrown into each
// other, the plate and the wall at up to 1 m/s, with a projectile landing on them: bead i of
// species[i] (0 for all in a world of one species).
dem::Simulation Heap(const dem::WorldParams& p, const std::vector<dem::Species>& species) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> unit(-1.0, 1.0), share(0.0, 1.0);
  dem::ParticleState beads;
  const double spacing = 0.0047;
  for (int iz = 0; beads.size() < species.size(); ++iz)
    for (int iy = -20; iy <= 20 && beads.size() < species.size(); ++iy)
      for (int ix = -20; ix <= 20 && beads.size() < species.size(); ++ix) {
        const dem::Vec3 x(ix * spacing + 1e-4 * unit(rng), iy * spacing + 1e-4 * unit(rng),
                          0.0026 + iz * spacing);
        if (x.head<2>().norm() > 0.0915) continue;
        beads.Add(x, 2.0e-3 + 2.5e-4 * share(rng), 2650.0, species[beads.size()]);
        beads.velocity.back() = dem::Vec3(unit(rng), unit(rng), unit(rng));
      }
  dem::RigidSphere projectile;
  projectile.radius = 0.025;
  projectile.mass = 0.167;
  projectile.position = dem::Vec3(0.0, 0.0, 0.042);
  projectile.velocity = dem::Vec3(0.0, 0.0, -3.0);
  return dem::Simulation(p, std::move(beads), projectile);
}

// Two species of one material, mixed, are the bed of one species: the same positions, forces
// and plate force to the bit, through every kind of contact (pairs, plate, wall, projectile)
// and on one thread or two.
TEST(Species, TwoSpeciesOfOneMaterialGiveTheOneSpeciesRunToTheBit) {
  Scene one;
  one.time.alpha = 0.2;
  Scene two = one;
  two.layers[0].fraction2 = 0.5;
  two.species[0] = {.name = "same",
                    .density_kg_m3 = one.material.density_kg_m3,
                    .youngs_modulus_Pa = one.material.youngs_modulus_Pa,
                    .poisson_ratio = one.material.poisson_ratio,
                    .restitution = one.material.restitution,
                    .friction_bead_bead = one.material.friction_bead_bead,
                    .friction_bead_wall = one.material.friction_bead_wall,
                    .diameter_min_m = one.beads.diameter_min_m,
                    .diameter_max_m = one.beads.diameter_max_m};
  dem::WorldParams p1 = BuildWorld(one).params, p2 = BuildWorld(two).params;
  ASSERT_EQ(p1.species.count, 1);
  ASSERT_EQ(p2.species.count, 2);
  EXPECT_EQ(p1.dt_s, p2.dt_s);
  constexpr std::size_t kBeads = 2500;  // above kParallelMinBeads: blocks and threads
  std::vector<dem::Species> none(kBeads, 0), mixed(kBeads);
  for (std::size_t i = 0; i < kBeads; ++i) mixed[i] = (i * 5 / 2) % 2;
  for (const int threads : {1, 2}) {
    p1.threads = p2.threads = threads;
    dem::Simulation a = Heap(p1, none), b = Heap(p2, mixed);
    ASSERT_GT(a.beads().size(), 1024u);
    long bead_contacts = 0, projectile_contacts = 0;
    for (int step = 0; step < 3000; ++step) {
      a.Step();
      b.Step();
      bead_contacts += a.observables().bead_contacts;
      projectile_contacts += a.observables().projectile_contacts;
      ASSERT_EQ(a.observables().plate_force_N, b.observables().plate_force_N) << step;
      ASSERT_EQ(a.observables().wall_force_z_N, b.observables().wall_force_z_N) << step;
      ASSERT_EQ(a.observables().projectile_force_N, b.observables().projectile_force_N) << step;
    }
    EXPECT_GT(bead_contacts, 10'000);  // contact-steps
    EXPECT_GT(projectile_contacts, 100);
    for (std::size_t i = 0; i < a.beads().size(); ++i)
      ASSERT_EQ(a.beads().position[i], b.beads().position[i]) << "bead " << i;
    EXPECT_EQ(a.Energy().elastic_J, b.Energy().elastic_J);
  }
}

// A cloud of beads of three species in free space (no gravity, no wall within reach), thrown
// into each other with friction and spin: each pair's forces are equal and opposite whatever
// its species, so momentum and angular momentum stay as they were.
TEST(Species, ACloudOfThreeSpeciesKeepsItsMomentumAndAngularMomentum) {
  Scene scene;
  scene.layers[0].fraction2 = scene.layers[0].fraction3 = 0.3;
  scene.species[1] = {.name = "polymer",
                      .density_kg_m3 = 1200.0,
                      .youngs_modulus_Pa = 3e8,
                      .poisson_ratio = 0.4,
                      .restitution = 0.5,
                      .friction_bead_bead = 0.9};
  scene.pairs.friction_1_2 = 0.3;
  const dem::WorldParams p = IsolatedWorld(scene, 0.1);
  ASSERT_EQ(p.species.count, 3);
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  dem::ParticleState beads;
  for (int ix = 0; ix < 10; ++ix)
    for (int iy = 0; iy < 10; ++iy)
      for (int iz = 0; iz < 10; ++iz) {
        const int kind = (ix + iy + iz) % 3;
        const double density = kind == 0 ? 2650.0 : scene.species[kind - 1].density_kg_m3;
        beads.Add(dem::Vec3(0.0046 * ix, 0.0046 * iy, 1.0 + 0.0046 * iz), 2.2e-3, density,
                  static_cast<dem::Species>(kind));
        beads.velocity.back() = 0.5 * dem::Vec3(unit(rng), unit(rng), unit(rng));
        beads.angular_velocity.back() = 100.0 * dem::Vec3(unit(rng), unit(rng), unit(rng));
      }
  dem::Simulation sim(p, std::move(beads), std::nullopt);
  auto momentum = [](const dem::ParticleState& b) {
    dem::Vec3 m = dem::Vec3::Zero(), l = dem::Vec3::Zero();
    for (std::size_t i = 0; i < b.size(); ++i) {
      m += b.mass[i] * b.velocity[i];
      l += b.mass[i] * b.position[i].cross(b.velocity[i]) + b.angular_velocity[i] / b.InvInertia(i);
    }
    return std::pair{m, l};
  };
  const auto [p0, l0] = momentum(sim.beads());
  double scale_p = 0.0, scale_l = 0.0;  // the sums of the magnitudes: what rounding acts on
  for (std::size_t i = 0; i < sim.beads().size(); ++i) {
    scale_p += sim.beads().mass[i] * sim.beads().velocity[i].norm();
    scale_l += sim.beads().mass[i] * sim.beads().position[i].cross(sim.beads().velocity[i]).norm() +
               sim.beads().angular_velocity[i].norm() / sim.beads().InvInertia(i);
  }
  long contacts = 0;
  for (int k = 0; k < 3000; ++k) {
    sim.Step();
    contacts += sim.observables().bead_contacts;
  }
  const auto [p1, l1] = momentum(sim.beads());
  EXPECT_LT((p1 - p0).norm(), 1e-10 * scale_p);
  EXPECT_LT((l1 - l0).norm(), 1e-9 * scale_l);
  EXPECT_GT(contacts, 10'000);  // they collided, species with species
}

}  // namespace
}  // namespace dembuf::test
