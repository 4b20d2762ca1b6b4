#include "dembuf/study/scene/contact_setup.h"

#include <cmath>

#include "dembuf/core/time_step.h"
#include "dembuf/study/scene/part_fields.h"

namespace dembuf {

double FallTime(double z0, double vz0, double z1, double gravity_m_s2) {
  const double drop = z0 - z1;
  if (drop <= 0.0) return 0.0;
  if (gravity_m_s2 == 0.0) return vz0 < 0.0 ? drop / -vz0 : -1.0;
  // z0 + vz0 t - g t^2 / 2 = z1, the later root (the body may first rise).
  return (vz0 + std::sqrt(vz0 * vz0 + 2.0 * gravity_m_s2 * drop)) / gravity_m_s2;
}

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
  setup.critical_dt_s = dem::CriticalTimeStep(min_radius_m, mat.density_kg_m3,
                                              mat.youngs_modulus_Pa, mat.poisson_ratio);
  wp.dt_s = scene.time.alpha * setup.critical_dt_s;
  return setup;
}

}  // namespace dembuf
