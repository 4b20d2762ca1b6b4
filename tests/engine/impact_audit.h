// An impact run watched step by step for the hard-case suite: every bead finite and inside
// the container, and the total energy (kinetic, potential, elastic) never above its start.
// Nothing does work on the system (the walls are fixed, gravity is in the potential), so any
// rise of the total is made by the integrator.
#pragma once

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <vector>

#include "dembuf/study/impact/impact.h"

namespace dembuf::test {

struct ImpactAudit {
  double start_energy_J = 0.0;
  double projectile_energy_J = 0.0;  ///< kinetic energy at the start: the scale of what moves
  double energy_gain_J = 0.0;        ///< the largest rise of the total above its start
  std::string problem;               ///< the first bead found non-finite or outside, if any
  std::int64_t steps = 0;
  double peak_plate_force_N = 0.0;
  double peak_wall_force_z_N = 0.0;  ///< largest magnitude
  double max_overlap_ratio = 0.0;
  double bed_surface_m = 0.0;
  double lowest_projectile_bottom_m = 0.0;     ///< above the plate
  double max_projectile_wall_overlap_m = 0.0;  ///< how far it went into the side wall
  dem::RigidSphere projectile_end;
  double final_plate_force_N = 0.0;
  double final_wall_force_z_N = 0.0;
  double weight_N = 0.0;  ///< of beads and projectile
  /// With `rest_from_step`: how far the projectile moved from that step to the end, and how
  /// many beads moved by more than a thousandth of their diameter.
  double late_projectile_displacement_m = 0.0;
  int late_moving_beads = 0;
  double final_bead_kinetic_J = 0.0;
};

/// The stress runs (DEMBUF_STRESS=1) scale the hard cases up: larger beds, longer runs.
inline bool StressMode() {
  const char* v = std::getenv("DEMBUF_STRESS");
  return v != nullptr && std::string(v) == "1";
}

/// Runs `scene` for `steps` steps from the projectile's start position (keep it just above
/// the bed: the audit integrates the flight too), checking every `check_every` steps. With
/// `rest_from_step` >= 0 it also measures how far anything moves after that step.
inline ImpactAudit AuditImpact(const Scene& scene, std::int64_t steps, int check_every = 20,
                               std::int64_t rest_from_step = -1) {
  World world = BuildWorld(scene);
  const dem::Container box = world.params.container;
  const double bed_surface = world.bed_surface_m;
  dem::Simulation sim(world.params, std::move(world.beads), world.projectile, world.history);
  sim.RefreshForces();
  ImpactAudit audit;
  audit.bed_surface_m = bed_surface;
  audit.start_energy_J = sim.Energy().Total();
  const double g = std::abs(scene.gravity_m_s2);
  for (std::size_t i = 0; i < sim.beads().size(); ++i) audit.weight_N += sim.beads().mass[i] * g;
  if (sim.projectile()) {
    const dem::RigidSphere& p = *sim.projectile();
    audit.projectile_energy_J = 0.5 * p.mass * p.velocity.squaredNorm();
    audit.weight_N += p.mass * g;
    audit.lowest_projectile_bottom_m = p.position.z() - p.radius;
  }
  auto check = [&] {
    const dem::ParticleState& b = sim.beads();
    for (std::size_t i = 0; i < b.size() && audit.problem.empty(); ++i) {
      const dem::Vec3& x = b.position[i];
      if (!x.allFinite() || !b.velocity[i].allFinite())
        audit.problem = "bead " + std::to_string(i) + " is not finite";
      else if (std::hypot(x.x(), x.y()) > box.radius_m + 0.5 * b.radius[i] || x.z() < -b.radius[i])
        audit.problem = "bead " + std::to_string(i) + " is outside the container";
    }
    audit.energy_gain_J =
        std::max(audit.energy_gain_J, sim.Energy().Total() - audit.start_energy_J);
  };
  std::vector<dem::Vec3> rest_positions;
  dem::Vec3 rest_projectile = dem::Vec3::Zero();
  for (std::int64_t k = 0; k < steps && audit.problem.empty(); ++k) {
    if (k == rest_from_step) {
      rest_positions = sim.beads().position;
      if (sim.projectile()) rest_projectile = sim.projectile()->position;
    }
    sim.Step();
    const dem::StepObservables& o = sim.observables();
    audit.peak_plate_force_N = std::max(audit.peak_plate_force_N, o.plate_force_N);
    audit.peak_wall_force_z_N = std::max(audit.peak_wall_force_z_N, std::abs(o.wall_force_z_N));
    audit.max_overlap_ratio = std::max(audit.max_overlap_ratio, o.max_overlap_ratio);
    if (sim.projectile()) {
      const dem::RigidSphere& p = *sim.projectile();
      audit.lowest_projectile_bottom_m =
          std::min(audit.lowest_projectile_bottom_m, p.position.z() - p.radius);
      audit.max_projectile_wall_overlap_m =
          std::max(audit.max_projectile_wall_overlap_m,
                   std::hypot(p.position.x(), p.position.y()) + p.radius - box.radius_m);
    }
    if ((k + 1) % check_every == 0) check();
  }
  check();
  if (!rest_positions.empty()) {
    const dem::ParticleState& b = sim.beads();
    for (std::size_t i = 0; i < rest_positions.size(); ++i)
      if ((b.position[i] - rest_positions[i]).norm() > 2e-3 * b.radius[i])
        ++audit.late_moving_beads;
    if (sim.projectile())
      audit.late_projectile_displacement_m = (sim.projectile()->position - rest_projectile).norm();
  }
  audit.final_bead_kinetic_J = sim.BeadKineticEnergy();
  audit.steps = sim.steps();
  if (sim.projectile()) audit.projectile_end = *sim.projectile();
  audit.final_plate_force_N = sim.observables().plate_force_N;
  audit.final_wall_force_z_N = sim.observables().wall_force_z_N;
  return audit;
}

}  // namespace dembuf::test
