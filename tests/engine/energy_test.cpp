// Energy conservation of the integrator with the full contact geometry (beads, plate,
// cylinder wall) when the law has no dissipation: e = 1 and no friction.
#include <gtest/gtest.h>

#include <random>

#include "dembuf/study/impact/impact.h"

namespace dembuf {
namespace {

// 500 beads on a loose jittered lattice, a column eight layers high in the paper's cylinder,
// thrown about at up to 1 m/s, bouncing under gravity off each other, the plate and the wall.
dem::Simulation BouncingBeads(double alpha) {
  Scene scene;
  scene.material.restitution = 1.0;
  scene.material.friction_bead_bead = 0.0;
  scene.material.friction_bead_wall = 0.0;
  scene.time.alpha = alpha;
  const World world = BuildWorld(scene);
  std::mt19937_64 rng(42);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  std::uniform_real_distribution<double> diameter(scene.beads.diameter_min_m,
                                                  scene.beads.diameter_max_m);
  dem::ParticleState beads;
  const double spacing = 0.0065;
  for (int iz = 0; beads.size() < 500; ++iz)
    for (int iy = -12; iy <= 12 && beads.size() < 500; ++iy)
      for (int ix = -12; ix <= 12 && beads.size() < 500; ++ix) {
        const double x = ix * spacing, y = iy * spacing;
        if (std::hypot(x, y) > 0.03) continue;
        beads.Add(dem::Vec3(x + 2e-4 * unit(rng), y + 2e-4 * unit(rng), 0.004 + iz * spacing),
                  0.5 * diameter(rng), scene.material.density_kg_m3);
        beads.velocity.back() = dem::Vec3(unit(rng), unit(rng), unit(rng));
      }
  return dem::Simulation(world.params, std::move(beads), std::nullopt);
}

TEST(Energy, ElasticFrictionlessBedConservesEnergyOver1e5Steps) {
  dem::Simulation sim = BouncingBeads(0.2);
  sim.RefreshForces();
  const double e0 = sim.Energy().Total();
  // The scale of the energy that moves around: kinetic plus potential above the plate.
  const dem::EnergyBreakdown start = sim.Energy();
  const double scale = start.kinetic_J + start.potential_J;
  double worst = 0.0;
  long contact_steps = 0;  // sum over steps of the bead-bead contacts
  for (int k = 0; k < 100'000; ++k) {
    sim.Step();
    contact_steps += sim.observables().bead_contacts;
    if (k % 1000 == 999) worst = std::max(worst, std::abs(sim.Energy().Total() - e0) / scale);
  }
  const double drift = std::abs(sim.Energy().Total() - e0) / scale;
  std::printf("energy drift after 1e5 steps: %.3g%% (worst sampled %.3g%%), %ld contact-steps\n",
              100 * drift, 100 * worst, contact_steps);
  EXPECT_LT(worst, 0.005);
  // The test means something only if the beads collided a lot: a 1 m/s contact lasts about
  // 8 steps, so this is thousands of bead-bead collisions (about 14 per bead when written).
  EXPECT_GT(contact_steps, 20'000);
}

}  // namespace
}  // namespace dembuf
