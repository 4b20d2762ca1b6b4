// The force pass against the contact law applied pair by pair over all pairs: the list, its
// blocks and batches, and the bead each entry is found to belong to must lose or misplace no
// contact. And what a simulation keeps between passes: no more than it needs.
#include <gtest/gtest.h>

#include <random>

#include "contact_kernels.h"
#include "dembuf/study/impact/impact.h"

namespace dembuf {
namespace {

// 3,000 beads (enough to be numbered in cell order and swept in blocks): blocks of up to
// 2 x 2 x 2 beads overlapping by up to 3% of a radius, scattered apart, so that many beads have
// no list entry and the batches of 256 entries start and end inside and between beads' runs;
// all moving and turning, away from the plate and the side wall.
//
// With `lone_layer`, the clusters leave room for a plane of beads across x, the axis of the
// grid's layers (the container is wider than the bed is high), so that the plane is in one
// layer, swept as one block. Its beads stand on a square lattice a little over a list's reach
// apart, and those of its bottom and top rows touch one more bead each: in cell order the
// block holds beads with entries, then a run of some 300 beads without any (more than a byte
// counts), then beads with entries again.
dem::ParticleState ClusteredBeads(const Scene& scene, bool lone_layer = false) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> unit(-1.0, 1.0), share(0.0, 1.0);
  std::uniform_int_distribution<int> side(1, 2);
  dem::ParticleState beads;
  const double r = 0.5 * scene.beads.diameter_min_m, spacing = 2.02 * r;
  auto add = [&](const dem::Vec3& c) {
    beads.Add(c, r * (1.0 + 0.04 * share(rng)), scene.material.density_kg_m3);
    beads.velocity.back() = 0.5 * dem::Vec3(unit(rng), unit(rng), unit(rng));
    beads.angular_velocity.back() = 200.0 * dem::Vec3(unit(rng), unit(rng), unit(rng));
  };
  if (lone_layer) {
    const double apart = 2.7 * r, bottom = 0.02, top = 0.02 + 14 * apart;
    for (double y = -0.06; y < 0.06; y += apart)
      for (double z = bottom; z < top + 0.5 * apart; z += apart) {
        add(dem::Vec3(0.0, y, z));
        if (z == bottom || z > top - 0.5 * apart) add(dem::Vec3(spacing, y, z));
      }
  }
  while (beads.size() < 3000) {
    const dem::Vec3 corner(0.06 * unit(rng), 0.06 * unit(rng), 0.02 + 0.08 * share(rng));
    if (lone_layer && std::abs(corner.x()) < 0.015) continue;  // room for the plane
    const int nx = side(rng), ny = side(rng), nz = side(rng);
    std::vector<dem::Vec3> cluster;
    for (int x = 0; x < nx; ++x)
      for (int y = 0; y < ny; ++y)
        for (int z = 0; z < nz; ++z) cluster.push_back(corner + spacing * dem::Vec3(x, y, z));
    bool clear = true;  // apart from the clusters placed before
    for (const dem::Vec3& c : cluster)
      for (const dem::Vec3& x : beads.position) clear = clear && (c - x).norm() > 2.3 * r;
    if (!clear) continue;
    for (const dem::Vec3& c : cluster) add(c);
  }
  return beads;
}

// One force pass over `beads` against the law applied pair by pair over all pairs, each with
// its kind of pair's constants (the scene's species); returns how many beads touch nothing.
int ExpectTheLawsForcesPairByPair(dem::ParticleState beads, const Scene& scene = Scene{}) {
  const World world = BuildWorld(scene);
  dem::Simulation sim(world.params, std::move(beads), std::nullopt);
  sim.RefreshForces();  // the first pass: every history starts at zero
  const dem::ParticleState& b = sim.beads();
  const dem::SpeciesTable& species = world.params.species;
  auto law_of = [&](std::size_t i, std::size_t j) -> const dem::PairParams& {
    return species.count > 1 ? species.BeadPair(b.species[i], b.species[j])
                             : world.params.sphere_pair;
  };
  const double dt = world.params.dt_s;

  std::vector<dem::Vec3> force(b.size(), dem::Vec3::Zero()), torque(b.size(), dem::Vec3::Zero());
  std::vector<int> contacts(b.size(), 0);
  int pairs = 0;
  for (std::size_t i = 0; i < b.size(); ++i)
    for (std::size_t j = i + 1; j < b.size(); ++j) {
      const dem::Vec3 d = b.position[i] - b.position[j];
      const double rsum = b.radius[i] + b.radius[j], dist = d.norm();
      if (dist >= rsum) continue;
      const double overlap = rsum - dist;
      const dem::Vec3 n = d / dist;
      const double ai = dem::detail::LeverArm(b.radius[i], overlap),
                   aj = dem::detail::LeverArm(b.radius[j], overlap);
      const dem::ContactGeometry g =
          dem::detail::MakeGeometry(n, overlap, b.velocity[i] - b.velocity[j],
                                    ai * b.angular_velocity[i] + aj * b.angular_velocity[j],
                                    dem::EffectiveRadius(b.radius[i], b.radius[j]));
      dem::Vec3 history = dem::Vec3::Zero();
      const dem::detail::ContactOutcome out =
          dem::detail::Resolve<dem::Effects<dem::Parts::Bit<dem::HertzNormal>() |
                                            dem::Parts::Bit<dem::MindlinTangential>()>>(
              g, ai, aj, {law_of(i, j), 0.0, dt}, history);
      force[i] += out.force;
      force[j] -= out.force;
      torque[i] += out.torque_i;
      torque[j] += out.torque_j;
      ++contacts[i];
      ++contacts[j];
      ++pairs;
    }
  int alone = 0;
  for (int c : contacts) alone += c == 0;
  EXPECT_GT(pairs, 1500);  // many contacts
  EXPECT_EQ(sim.observables().bead_contacts, pairs);

  // Sums in another order: equal to rounding, against the largest force of the bed.
  double largest_force = 0.0, largest_torque = 0.0;
  for (std::size_t i = 0; i < b.size(); ++i) {
    largest_force = std::max(largest_force, force[i].norm());
    largest_torque = std::max(largest_torque, torque[i].norm());
  }
  int wrong = 0;
  for (std::size_t i = 0; i < b.size(); ++i) {
    const bool same = (b.force[i] - force[i]).norm() <= 1e-12 * largest_force &&
                      (b.torque[i] - torque[i]).norm() <= 1e-12 * largest_torque;
    if (!same && ++wrong <= 5)
      ADD_FAILURE() << "bead " << i << " (" << contacts[i] << " contacts): force "
                    << b.force[i].transpose() << ", by the law pair by pair "
                    << force[i].transpose();
  }
  EXPECT_EQ(wrong, 0);
  return alone;
}

TEST(ForcePass, EveryBeadGetsTheLawsForcesSummedOverAllItsContacts) {
  const Scene scene;
  EXPECT_GT(ExpectTheLawsForcesPairByPair(ClusteredBeads(scene)), 300);
}

// Beads of three species of distinct materials, mixed: each contact of the vectorized pass
// takes its kind of pair's constants (the table's row and column the right way round).
TEST(ForcePass, EachContactOfSeveralSpeciesGetsItsPairsLaw) {
  Scene scene;
  scene.layers[0].fraction2 = 0.3;
  scene.layers[0].fraction3 = 0.3;
  scene.species[0].restitution = 0.5;
  scene.species[0].friction_bead_bead = 0.2;
  scene.species[1] = {.name = "rubber",
                      .density_kg_m3 = 1100.0,
                      .youngs_modulus_Pa = 5e7,
                      .poisson_ratio = 0.45,
                      .restitution = 0.6,
                      .friction_bead_bead = 0.9};
  scene.pairs.friction_1_3 = 0.05;
  dem::ParticleState beads = ClusteredBeads(scene);
  for (std::size_t i = 0; i < beads.size(); ++i) beads.species[i] = (i * 7 / 3) % 3;
  EXPECT_GT(ExpectTheLawsForcesPairByPair(beads, scene), 300);
  const World world = BuildWorld(scene);
  ASSERT_EQ(world.params.species.count, 3);
  // Distinct constants for each kind: a table read the wrong way would be seen.
  EXPECT_NE(world.params.species.BeadPair(0, 1).friction,
            world.params.species.BeadPair(0, 2).friction);
  EXPECT_NE(world.params.species.BeadPair(1, 2).kn_per_sqrt_r,
            world.params.species.BeadPair(0, 2).kn_per_sqrt_r);
}

// Some 300 beads in a row without entries inside one block and one batch: the force pass must
// step over all of them to the next entry's bead.
TEST(ForcePass, ALongRunOfBeadsWithoutContactsMisplacesNoForce) {
  const Scene scene;
  EXPECT_GT(ExpectTheLawsForcesPairByPair(ClusteredBeads(scene, true)), 300);
}

// The lists outlive many steps: each pass must still find every touching pair. The beads fly
// apart and into each other at up to 2 m/s, so that the lists are built again and again.
TEST(ForcePass, ListsKeptOverStepsMissNoTouchingPair) {
  const Scene scene;
  const World world = BuildWorld(scene);
  dem::ParticleState beads = ClusteredBeads(scene);
  for (dem::Vec3& v : beads.velocity) v *= 4.0;
  dem::Simulation sim(world.params, std::move(beads), std::nullopt);
  int checked = 0;
  for (int step = 1; step <= 400; ++step) {
    sim.Step();
    if (step % 25 != 0) continue;
    const dem::ParticleState& b = sim.beads();
    int touching = 0;
    for (std::size_t i = 0; i < b.size(); ++i)
      for (std::size_t j = i + 1; j < b.size(); ++j) {
        const double rsum = b.radius[i] + b.radius[j];
        touching += (b.position[i] - b.position[j]).squaredNorm() < rsum * rsum;
      }
    EXPECT_EQ(sim.observables().bead_contacts, touching) << "step " << step;
    checked += touching > 0;
  }
  EXPECT_EQ(checked, 16);
  // The lists were built again many times, and their far pairs sorted in between, so the
  // test saw what it is about.
  EXPECT_GT(sim.stage_times().list_builds, 5);
  EXPECT_GT(sim.stage_times().pair_sorts, 20);
}

// A bead that leaves the plate or the side wall forgets its spring with it, as a pair that
// opens does: each bead starts 1% of its radius deep, sliding along the wall and moving away.
// Without damping: the damping clamps the normal force to zero before the bead is off, and a
// spring capped at zero force is zero already.
TEST(ForcePass, ABeadThatLeavesAWallForgetsItsSpring) {
  const Scene scene;
  World world = BuildWorld(scene);
  world.params.sphere_wall.damping_A_s = 0.0;
  const double r = 0.5 * scene.beads.diameter_min_m, wall = world.params.container.radius_m;
  dem::ParticleState beads;
  beads.Add(dem::Vec3(0.0, 0.0, 0.99 * r), r, scene.material.density_kg_m3);
  beads.velocity.back() = dem::Vec3(0.2, 0.0, 0.3);
  beads.Add(dem::Vec3(wall - 0.99 * r, 0.0, 0.02), r, scene.material.density_kg_m3);
  beads.velocity.back() = dem::Vec3(-0.3, 0.2, 0.0);
  dem::Simulation sim(world.params, std::move(beads), std::nullopt);
  auto springs = [&](dem::BodyId with) {
    int count = 0;
    for (const dem::ContactHistoryEntry& h : sim.ExportHistory()) count += h.other == with;
    return count;
  };
  sim.Step();
  ASSERT_EQ(springs(dem::kPlate), 1);
  ASSERT_EQ(springs(dem::kSideWall), 1);
  for (int step = 0; step < 100; ++step) sim.Step();  // 0.3 m/s: 45 um away, 10 um deep
  EXPECT_EQ(sim.observables().plate_force_N, 0.0);
  EXPECT_EQ(springs(dem::kPlate), 0);
  EXPECT_EQ(springs(dem::kSideWall), 0);
  EXPECT_EQ(sim.stage_times().list_builds, 0);  // no build since the first: same slots
}

// A bed loaded with its springs hands them to the first list build; after that they must not
// be held twice (they are some 60 bytes a bead).
TEST(Simulation, ASavedHistoryIsLetGoOnceApplied) {
  const Scene scene;
  const World world = BuildWorld(scene);
  dem::Simulation first(world.params, ClusteredBeads(scene), std::nullopt);
  for (int k = 0; k < 3; ++k) first.Step();
  const std::vector<dem::ContactHistoryEntry> history = first.ExportHistory();
  ASSERT_GT(history.size(), 2000u);

  dem::Simulation with_springs(world.params, first.beads(), std::nullopt, history);
  dem::Simulation without(world.params, first.beads(), std::nullopt);
  with_springs.Step();
  without.Step();
  // The springs were carried on (a few contacts open in the step), not dropped.
  EXPECT_GT(with_springs.ExportHistory().size(), 9 * history.size() / 10);
  EXPECT_EQ(with_springs.MemoryBytes(), without.MemoryBytes());
}

}  // namespace
}  // namespace dembuf
