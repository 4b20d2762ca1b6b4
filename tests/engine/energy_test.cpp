// Energy conservation of the integrator with the full contact geometry (beads, plate,
// cylinder wall) when the law has no dissipation: e = 1 and no friction.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "dembuf/study/impact/impact.h"

namespace dembuf {
namespace {

// How the beads are of species: all of species 1, three species mixed, or three in layers.
enum class Species { kOne, kMixed, kLayered };

// 500 beads on a loose jittered lattice, a column eight layers high in the paper's cylinder,
// thrown about at up to 1 m/s, bouncing under gravity off each other, the plate and the wall.
// Of several species: steel shot and a soft polymer besides the glass, elastic and
// frictionless too, mixed bead by bead or in layers of a third of the column each.
dem::Simulation BouncingBeads(double alpha, Species species = Species::kOne) {
  Scene scene;
  scene.material.restitution = 1.0;
  scene.material.friction_bead_bead = 0.0;
  scene.material.friction_bead_wall = 0.0;
  scene.time.alpha = alpha;
  if (species != Species::kOne) {
    scene.layers[0].fraction2 = scene.layers[0].fraction3 = 0.3;
    scene.species[0] = {
        .name = "steel", .restitution = 1.0, .friction_bead_bead = 0.0, .friction_bead_wall = 0.0};
    scene.species[1] = {.name = "polymer",
                        .density_kg_m3 = 1200.0,
                        .youngs_modulus_Pa = 3e8,
                        .poisson_ratio = 0.4,
                        .restitution = 1.0,
                        .friction_bead_bead = 0.0,
                        .friction_bead_wall = 0.0};
  }
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
        const int kind = species == Species::kMixed     ? static_cast<int>(beads.size() % 3)
                         : species == Species::kLayered ? std::min(iz / 3, 2)
                                                        : 0;
        const double density =
            kind == 0 ? scene.material.density_kg_m3 : scene.species[kind - 1].density_kg_m3;
        beads.Add(dem::Vec3(x + 2e-4 * unit(rng), y + 2e-4 * unit(rng), 0.004 + iz * spacing),
                  0.5 * diameter(rng), density, static_cast<dem::Species>(kind));
        beads.velocity.back() = dem::Vec3(unit(rng), unit(rng), unit(rng));
      }
  return dem::Simulation(world.params, std::move(beads), std::nullopt);
}

class Energy : public testing::TestWithParam<Species> {};

TEST_P(Energy, ElasticFrictionlessBedConservesEnergyOver1e5Steps) {
  dem::Simulation sim = BouncingBeads(0.2, GetParam());
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

INSTANTIATE_TEST_SUITE_P(OfSpecies, Energy,
                         testing::Values(Species::kOne, Species::kMixed, Species::kLayered),
                         [](const testing::TestParamInfo<Species>& info) {
                           return info.param == Species::kOne     ? "one_species"
                                  : info.param == Species::kMixed ? "mixed"
                                                                  : "layered";
                         });

}  // namespace
}  // namespace dembuf
