#include "dembuf/engine/impact.h"

#include <chrono>
#include <cmath>
#include <limits>
#include <numbers>

#include "dembuf/engine/bed_io.h"
#include "dembuf/engine/errors.h"
#include "dembuf/engine/scene_fields.h"
#include "dembuf/engine/time_step.h"

namespace dembuf {

double FallTime(double z0, double vz0, double z1, double gravity_m_s2) {
  const double drop = z0 - z1;
  if (drop <= 0.0) return 0.0;
  if (gravity_m_s2 == 0.0) return vz0 < 0.0 ? drop / -vz0 : -1.0;
  // z0 + vz0 t - g t^2 / 2 = z1, the later root (the body may first rise).
  return (vz0 + std::sqrt(vz0 * vz0 + 2.0 * gravity_m_s2 * drop)) / gravity_m_s2;
}

World BuildWorld(const Scene& scene) {
  ValidateScene(scene);
  if (!scene.projectile.enabled && scene.time.end_s == 0.0)
    throw SceneError("time.end_s",
                     "must be > 0 when projectile.enabled = false (the automatic "
                     "end waits for the projectile's impact)");
  World world;
  const MaterialSpec& mat = scene.material;
  const ShearStiffness shear =
      mat.shear_stiffness == "mindlin" ? ShearStiffness::kMindlin : ShearStiffness::kPaper;
  const Elastic bead_elastic{mat.youngs_modulus_Pa, mat.poisson_ratio};
  const Elastic wall_elastic =
      scene.walls.material_from_beads
          ? bead_elastic
          : Elastic{scene.walls.youngs_modulus_Pa, scene.walls.poisson_ratio};
  const PairModuli pair_moduli = EffectiveModuli(bead_elastic, bead_elastic, shear);
  const PairModuli wall_moduli = EffectiveModuli(bead_elastic, wall_elastic, shear);

  // Calibrate A on two beads of the mean diameter meeting head-on (MODEL.md section 2).
  const double d_mean = 0.5 * (scene.beads.diameter_min_m + scene.beads.diameter_max_m);
  const double bead_mass = mat.density_kg_m3 * std::numbers::pi / 6.0 * d_mean * d_mean * d_mean;
  const double kn_ref = 4.0 / 3.0 * pair_moduli.e_star * std::sqrt(0.25 * d_mean);
  world.damping =
      CalibrateDamping(mat.restitution, mat.restitution_ref_speed_m_s, kn_ref, 0.5 * bead_mass);
  const double A = world.damping.damping_A_s;

  WorldParams& wp = world.params;
  wp.container = {scene.cylinder.radius_m, scene.cylinder.height_m};
  wp.sphere_pair = MakePairParams(pair_moduli, A, mat.friction_bead_bead);
  wp.sphere_wall = MakePairParams(wall_moduli, A, mat.friction_bead_wall);
  wp.gravity_m_s2 = scene.gravity_m_s2;

  if (!scene.bed.import.empty()) {
    world.beads = ImportTextBed(scene.bed.import, scene);
  } else if (scene.bed.thickness_m > 0.0) {
    throw SceneError("bed.thickness_m",
                     "preparing a bed is not available in this version; set bed.thickness_m = 0 "
                     "or give a bed file with bed.import");
  }
  world.bed_surface_m = BedSurfaceHeight(world.beads);

  double min_radius = 0.5 * scene.beads.diameter_min_m;
  for (double r : world.beads.radius) min_radius = std::min(min_radius, r);
  world.critical_dt_s =
      CriticalTimeStep(min_radius, mat.density_kg_m3, mat.youngs_modulus_Pa, mat.poisson_ratio);
  wp.dt_s = scene.time.alpha * world.critical_dt_s;

  if (scene.projectile.enabled) {
    RigidSphere p;
    p.radius = 0.5 * scene.projectile.diameter_m;
    p.mass = scene.projectile.mass_kg;
    p.position = Vec3(0.0, 0.0, world.bed_surface_m + scene.projectile.height_m);
    p.velocity = Vec3(0.0, 0.0, -scene.projectile.speed_m_s);
    world.projectile = p;
  }
  return world;
}

namespace {

// Emits samples on the global grid t = k * interval, so that runs line up sample by sample.
class SampleClock {
 public:
  explicit SampleClock(double interval) : m_interval(interval) {}
  bool Due(double t) const { return t >= m_next * m_interval * (1.0 - 1e-12); }
  void Advance(double t) {
    while (Due(t)) ++m_next;
  }
  double NextTime() const { return m_next * m_interval; }

 private:
  double m_interval;
  std::int64_t m_next = 0;
};

ImpactSample MakeSample(const Simulation& sim) {
  const StepObservables& o = sim.observables();
  ImpactSample s{sim.time_s(),
                 o.plate_force_N,
                 o.wall_force_z_N,
                 std::numeric_limits<double>::quiet_NaN(),
                 0.0,
                 0.0};
  if (sim.projectile()) {
    s.projectile_z_m = sim.projectile()->position.z();
    s.projectile_vz_m_s = sim.projectile()->velocity.z();
    s.projectile_force_z_N = o.projectile_force_N.z();
  }
  return s;
}

}  // namespace

ImpactSummary RunImpact(const Scene& scene, const RunControl& control) {
  return RunImpact(BuildWorld(scene), scene, control);
}

ImpactSummary RunImpact(World world, const Scene& scene, const RunControl& control) {
  const auto wall_start = std::chrono::steady_clock::now();
  ImpactSummary summary;
  summary.beads = world.beads.size();
  summary.dt_s = world.params.dt_s;
  summary.critical_dt_s = world.critical_dt_s;
  summary.damping = world.damping;
  summary.bed_surface_m = world.bed_surface_m;

  Simulation sim(world.params, std::move(world.beads), world.projectile);
  sim.RefreshForces();  // the resting load of the bed, felt during the free flight
  SampleClock clock(scene.time.output_interval_s);
  auto emit = [&](const ImpactSample& s) {
    if (control.on_sample) control.on_sample(s);
  };

  const double g = scene.gravity_m_s2;
  const double t_limit =
      scene.time.end_s > 0.0 ? scene.time.end_s : std::numeric_limits<double>::infinity();
  double t_end_estimate = t_limit;

  // Free flight: nothing but gravity acts on the projectile until its lowest point reaches
  // the top of the bed, and the resting bed does not change meanwhile. Jump there analytically,
  // stopping a few steps short so that the first contact is integrated from its start.
  if (sim.projectile()) {
    RigidSphere p = *sim.projectile();
    const double speed_bound = std::abs(p.velocity.z()) + std::sqrt(2.0 * g * p.position.z());
    const double margin = 4.0 * speed_bound * world.params.dt_s;
    const double target = world.bed_surface_m + p.radius + margin;
    double t_fly = FallTime(p.position.z(), p.velocity.z(), target, g);
    if (t_fly < 0.0) t_fly = std::isfinite(t_limit) ? t_limit : 0.0;
    t_fly = std::min(t_fly, t_limit);
    if (t_fly > 0.0) {
      ImpactSample s = MakeSample(sim);
      const double z0 = p.position.z(), vz0 = p.velocity.z();
      for (double t = clock.NextTime(); t <= t_fly; clock.Advance(t), t = clock.NextTime()) {
        s.t_s = t;
        s.projectile_z_m = z0 + vz0 * t - 0.5 * g * t * t;
        s.projectile_vz_m_s = vz0 - g * t;
        emit(s);
      }
      p.position.z() = z0 + vz0 * t_fly - 0.5 * g * t_fly * t_fly;
      p.velocity.z() = vz0 - g * t_fly;
      sim.SetProjectile(p, t_fly);
      sim.RefreshForces();
      summary.free_flight_s = t_fly;
      summary.impact_speed_m_s = std::abs(p.velocity.z());
    }
    if (scene.time.end_s == 0.0) t_end_estimate = t_fly + scene.time.impact_window_s;
  }

  // The impact, step by step.
  double peak = sim.observables().plate_force_N;
  double peak_time = sim.time_s();
  double rest_since = -1.0;  // when the projectile last became slow
  const double slow_speed = 0.01 * std::max(summary.impact_speed_m_s, 1e-3);
  std::int64_t next_progress = control.progress_every_steps;
  while (true) {
    if (sim.time_s() >= t_limit) {
      summary.end_reason = "reached time.end_s";
      break;
    }
    sim.Step();
    const StepObservables& o = sim.observables();
    const double t = sim.time_s();
    if (o.plate_force_N > peak) {
      peak = o.plate_force_N;
      peak_time = t;
    }
    if (clock.Due(t)) {
      emit(MakeSample(sim));
      clock.Advance(t);
    }
    if (sim.steps() >= next_progress) {
      next_progress += control.progress_every_steps;
      if (control.cancel && control.cancel->load(std::memory_order_relaxed)) throw Cancelled();
      if (control.on_progress) control.on_progress({t, t_end_estimate, sim.steps()});
    }
    if (!sim.projectile()) continue;

    const RigidSphere& p = *sim.projectile();
    if (summary.first_contact_time_s < 0.0) {
      if (o.projectile_contacts > 0) summary.first_contact_time_s = t;
      continue;
    }
    if (scene.time.end_s > 0.0) continue;
    // Automatic end (time.end_s = 0): the projectile has bounced clear, or has been at rest
    // for a millisecond, or the impact window has passed.
    if (o.projectile_contacts == 0 && p.velocity.z() > 0.0) {
      summary.end_reason = "projectile rebounded clear";
      break;
    }
    if (p.velocity.norm() < slow_speed) {
      if (rest_since < 0.0) rest_since = t;
      if (t - rest_since >= 1e-3) {
        summary.end_reason = "projectile at rest";
        break;
      }
    } else {
      rest_since = -1.0;
    }
    if (t >= summary.first_contact_time_s + scene.time.impact_window_s) {
      summary.end_reason = "time.impact_window_s elapsed";
      break;
    }
  }
  if (control.on_progress) control.on_progress({sim.time_s(), sim.time_s(), sim.steps()});

  summary.peak_plate_force_N = peak;
  summary.peak_plate_force_time_s = peak_time;
  summary.steps = sim.steps();
  summary.end_time_s = sim.time_s();
  summary.wall_time_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  return summary;
}

}  // namespace dembuf
