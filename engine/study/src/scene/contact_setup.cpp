#include "dembuf/study/scene/contact_setup.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "dembuf/core/time_step.h"
#include "dembuf/study/scene/part_fields.h"
#include "dembuf/study/scene/species.h"

namespace dembuf {

double FallTime(double z0, double vz0, double z1, double gravity_m_s2) {
  const double drop = z0 - z1;
  if (drop <= 0.0) return 0.0;
  if (gravity_m_s2 == 0.0) return vz0 < 0.0 ? drop / -vz0 : -1.0;
  // z0 + vz0 t - g t^2 / 2 = z1, the later root (the body may first rise).
  return (vz0 + std::sqrt(vz0 * vz0 + 2.0 * gravity_m_s2 * drop)) / gravity_m_s2;
}

double CriticalTimeStepOf(const Scene& scene, double min_radius_m) {
  // Eq. 6 for each species in the bed, at the smallest bead's radius: the quickest sets the
  // step.
  double dt = HUGE_VAL;
  for (int k = 0; k < SpeciesCount(scene); ++k) {
    if (!HasBeadsOf(scene, k)) continue;
    const SpeciesMaterial m = SpeciesOf(scene, k);
    dt = std::min(dt, dem::CriticalTimeStep(min_radius_m, m.density_kg_m3, m.youngs_modulus_Pa,
                                            m.poisson_ratio));
  }
  return dt;
}

namespace {

// The pairs of a world of several species (SpeciesTable): species a with b by their materials,
// the damping calibrated for each pair from its restitution with two mean beads of the pair
// (halves where the two are alike, so that two species of one material get that material's
// constants to the bit), the walls' pairs with each species' own damping, and the projectile,
// of species 1's material, on each.
dem::SpeciesTable MakeSpeciesTable(const Scene& scene, dem::ShearStiffness shear,
                                   const dem::Elastic& wall_elastic) {
  const int count = SpeciesCount(scene);
  std::vector<SpeciesMaterial> species;
  for (int k = 0; k < count; ++k) species.push_back(SpeciesOf(scene, k));
  dem::SpeciesTable table;
  table.count = count;
  table.bead_pair.resize(static_cast<std::size_t>(count * count));
  std::vector<double> own_damping(count);
  for (int a = 0; a < count; ++a)
    for (int b = a; b < count; ++b) {
      const SpeciesMaterial &ma = species[a], &mb = species[b];
      const dem::PairModuli moduli =
          dem::EffectiveModuli({ma.youngs_modulus_Pa, ma.poisson_ratio},
                               {mb.youngs_modulus_Pa, mb.poisson_ratio}, shear);
      const double ra = 0.5 * ma.MeanDiameter(), rb = 0.5 * mb.MeanDiameter();
      const double r_star = ra == rb ? 0.5 * ra : ra * rb / (ra + rb);
      const double m_a = ma.MeanMass(), m_b = mb.MeanMass();
      const double m_star = m_a == m_b ? 0.5 * m_a : m_a * m_b / (m_a + m_b);
      const double kn_ref = 4.0 / 3.0 * moduli.e_star * std::sqrt(r_star);
      const double A =
          dem::CalibrateDamping(PairRestitution(scene, a, b),
                                scene.material.restitution_ref_speed_m_s, kn_ref, m_star)
              .damping_A_s;
      if (a == b) own_damping[a] = A;
      const dem::PairParams pair = dem::MakePairParams(moduli, A, PairFriction(scene, a, b));
      table.bead_pair[static_cast<std::size_t>(a * count + b)] = pair;
      table.bead_pair[static_cast<std::size_t>(b * count + a)] = pair;
    }
  for (int k = 0; k < count; ++k) {
    const dem::Elastic elastic{species[k].youngs_modulus_Pa, species[k].poisson_ratio};
    table.bead_wall.push_back(
        dem::MakePairParams(dem::EffectiveModuli(elastic, wall_elastic, shear), own_damping[k],
                            species[k].friction_bead_wall));
    table.projectile_bead.push_back(table.BeadPair(0, static_cast<dem::Species>(k)));
  }
  return table;
}

}  // namespace

ContactSetup MakeContactSetup(const Scene& scene, double min_radius_m) {
  ContactSetup setup;
  const MaterialSpec& mat = scene.material;
  const dem::ShearStiffness shear = mat.shear_stiffness == "mindlin" ? dem::ShearStiffness::kMindlin
                                                                     : dem::ShearStiffness::kPaper;
  const dem::Elastic bead_elastic{mat.youngs_modulus_Pa, mat.poisson_ratio};
  const dem::Elastic wall_elastic =
      scene.walls.material_from_beads
          ? bead_elastic
          : dem::Elastic{scene.walls.youngs_modulus_Pa, scene.walls.poisson_ratio};
  const dem::PairModuli pair_moduli = dem::EffectiveModuli(bead_elastic, bead_elastic, shear);
  const dem::PairModuli wall_moduli = dem::EffectiveModuli(bead_elastic, wall_elastic, shear);

  // Calibrate A on two beads of the mean diameter meeting head-on (docs/model.md section 2).
  const double d_mean = scene.beads.MeanDiameter();
  const double bead_mass = scene.MeanBeadMass();
  const double kn_ref = 4.0 / 3.0 * pair_moduli.e_star * std::sqrt(0.25 * d_mean);
  setup.contact_damping = dem::CalibrateDamping(mat.restitution, mat.restitution_ref_speed_m_s,
                                                kn_ref, 0.5 * bead_mass);
  const double A = setup.contact_damping.damping_A_s;

  dem::WorldParams& wp = setup.params;
  wp.container = {scene.cylinder.radius_m, scene.cylinder.height_m};
  wp.sphere_pair = dem::MakePairParams(pair_moduli, A, mat.friction_bead_bead);
  wp.sphere_wall = dem::MakePairParams(wall_moduli, A, mat.friction_bead_wall);
  SetRollingResistance(scene, wp);
  wp.gravity_m_s2 = scene.gravity_m_s2;
  setup.critical_dt_s = CriticalTimeStepOf(scene, min_radius_m);
  if (SpeciesCount(scene) > 1) wp.species = MakeSpeciesTable(scene, shear, wall_elastic);
  wp.dt_s = scene.time.alpha * setup.critical_dt_s;
  return setup;
}

}  // namespace dembuf
