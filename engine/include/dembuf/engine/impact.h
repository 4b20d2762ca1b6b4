// One impact run from a Scene: build the world (materials, calibrated damping, time step, bed,
// projectile), fly the projectile analytically to just above the bed, integrate the impact and
// report. This is what the CLI's local mode and the daemon's workers call.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>

#include "dembuf/engine/damping.h"
#include "dembuf/engine/scene.h"
#include "dembuf/engine/simulation.h"

namespace dembuf {

/// Everything a Simulation needs, derived from a Scene.
struct World {
  WorldParams params;
  ParticleState beads;
  std::optional<RigidSphere> projectile;  ///< at its start position (centre H1 above the bed)
  DampingCalibration damping;
  double critical_dt_s = 0.0;  ///< eq. 6
  double bed_surface_m = 0.0;  ///< height of the bed surface (0 without beads)
};

/// Validates the scene and derives the world. Throws SceneError.
World BuildWorld(const Scene& scene);

/// One written sample of the run.
struct ImpactSample {
  double t_s;
  double plate_force_N;
  double wall_force_z_N;
  double projectile_z_m;  ///< centre height (NaN without a projectile)
  double projectile_vz_m_s;
  double projectile_force_z_N;  ///< vertical contact force on the projectile
};

struct ImpactProgress {
  double t_s;
  double t_end_estimate_s;  ///< the end time, or an upper bound when the end is automatic
  std::int64_t steps;
};

/// How the caller watches and steers a run.
struct RunControl {
  std::function<void(const ImpactSample&)> on_sample;  ///< every time.output_interval_s
  std::function<void(const ImpactProgress&)> on_progress;
  std::int64_t progress_every_steps = 4096;
  const std::atomic<bool>* cancel = nullptr;  ///< checked every progress interval; throws Cancelled
};

struct ImpactSummary {
  double peak_plate_force_N = 0.0;  ///< over every step, not only the written samples
  double peak_plate_force_time_s = 0.0;
  std::size_t beads = 0;
  double dt_s = 0.0;
  double critical_dt_s = 0.0;
  std::int64_t steps = 0;  ///< integrated steps (the analytic free flight takes none)
  double wall_time_s = 0.0;
  DampingCalibration damping;
  double bed_surface_m = 0.0;
  double free_flight_s = 0.0;          ///< time covered analytically
  double first_contact_time_s = -1.0;  ///< -1: the projectile never touched anything
  double impact_speed_m_s = 0.0;       ///< projectile speed at the end of the free flight
  double end_time_s = 0.0;
  std::string end_reason;
};

/// Runs the scene. Throws SceneError for a bad scene, SimulationError when the run becomes
/// unstable and Cancelled when the cancel flag is raised.
ImpactSummary RunImpact(const Scene& scene, const RunControl& control = {});

/// The same, for a world already built from `scene` (so that a caller can check the scene
/// before creating any output).
ImpactSummary RunImpact(World world, const Scene& scene, const RunControl& control = {});

/// Free flight under gravity: time until the projectile's centre, starting at height z0 with
/// vertical velocity vz0 (positive up), comes down to height z1 < z0. Returns -1 if never.
double FallTime(double z0, double vz0, double z1, double gravity_m_s2);

}  // namespace dembuf
