// One impact run from a Scene: build the world (materials, calibrated damping, time step, bed,
// projectile), fly the projectile analytically to just above the bed, integrate the impact and
// report. RunJob (run/run_job.h) calls it for a local run, a sweep's run and a daemon's job.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "dembuf/core/damping.h"
#include "dembuf/core/simulation.h"
#include "dembuf/study/bed/bed.h"
#include "dembuf/study/impact/peaks.h"
#include "dembuf/study/scene/contact_setup.h"
#include "dembuf/study/scene/scene.h"

namespace dembuf {

/// What the run reports of its bed.
struct BedSummary {
  std::string hash;             ///< the cache key: of the scene fields that make the bed
  std::string sha256;           ///< of the bed itself, its beads and springs (BedContentSha256)
  double thickness_m = 0.0;     ///< measured H
  double solid_fraction = 0.0;  ///< measured C0
  double rest_plate_force_N = 0.0;
  double rest_wall_force_z_N = 0.0;
  double weight_N = 0.0;
  std::string note;                   ///< an imported bed's overlaps, as read
  std::vector<std::string> warnings;  ///< where an imported file disagrees with the scene
  /// A bed of several species or layers: the species' names (0-based) and each layer.
  std::vector<std::string> species;
  std::vector<LayerSummary> layers;
};

/// Everything a Simulation needs, derived from a Scene.
struct World {
  dem::WorldParams params;
  dem::ParticleState beads;
  std::vector<dem::ContactHistoryEntry> history;  ///< the bed's tangential springs
  std::optional<dem::RigidSphere> projectile;  ///< at its start position (centre H1 above the bed)
  dem::DampingCalibration contact_damping;
  double critical_dt_s = 0.0;  ///< eq. 6
  double bed_surface_m = 0.0;  ///< height of the bed surface (0 without beads)
  BedSummary bed;
};

class BedCache;
struct BedRequest;

/// Validates the scene and derives the world; a bed comes from `cache` or is prepared and
/// stored there (a private in-memory cache when null). Throws SceneError.
World BuildWorld(const Scene& scene, BedCache* cache = nullptr,
                 const BedRequest* request = nullptr);

/// One written sample of the run.
struct ImpactSample {
  double t_s;
  double plate_force_N;
  double wall_force_z_N;
  double projectile_z_m;  ///< centre height (NaN without a projectile)
  double projectile_vz_m_s;
  double projectile_force_z_N;  ///< vertical contact force on the projectile
};

/// The state of the bed at one instant: bead positions and radii, the projectile, and every
/// contact with its force (for force chains, the plate load map and force statistics).
struct ImpactSnapshot {
  /// Its folder name: "after_contact_0.5ms" (output.snapshot_after_contact_s), "t_57.2ms"
  /// (output.snapshot_times_s) or "peak".
  std::string label;
  double t_s = 0.0;
  double t_after_contact_s = std::numeric_limits<double>::quiet_NaN();  ///< NaN: before contact
  std::vector<dem::Vec3> positions;
  std::vector<double> radii;
  std::vector<dem::Vec3> velocities;
  std::vector<dem::Vec3> forces;      ///< each bead's contact force (gravity apart)
  std::vector<std::uint32_t> ids;     ///< each bead's index in the bed (stable from frame to frame)
  std::vector<dem::Species> species;  ///< each bead's species (0-based; empty: all species 1)
  std::optional<dem::RigidSphere> projectile;
  std::vector<dem::ContactSnapshot> contacts;  ///< none in an animation frame
};

struct ImpactProgress {
  double t_s;
  double t_end_estimate_s;  ///< the end time, or an upper bound when the end is automatic
  std::int64_t steps;
};

/// How a caller steers a run and hears how far it is: one part of the impact's RunControl and
/// of RunJob's JobControl alike.
struct RunSteering {
  const std::atomic<bool>* cancel = nullptr;  ///< checked every step; the run throws Cancelled
  /// How many engine threads the run may use now, read every step (null: the default).
  /// Results do not depend on it.
  const std::atomic<int>* threads = nullptr;
  std::function<void(const ImpactProgress&)> on_progress;  ///< while the impact runs
  std::int64_t progress_every_steps = 4096;
};

/// How the caller watches and steers an impact.
struct RunControl {
  RunSteering steering;
  std::function<void(const ImpactSample&)> on_sample;      ///< every time.output_interval_s
  std::function<void(const ImpactSnapshot&)> on_snapshot;  ///< scene.output snapshots
  /// Animation frames, every output.animation_interval_s of the impact (the beads' states,
  /// no contacts), labelled "frame_00000", "frame_00001", ...
  std::function<void(const ImpactSnapshot&)> on_frame;
  /// Run the same projectile on the bare plate to get Pa0 for the buffer ratio lambda.
  bool compute_reference = true;
  /// The samples of that bare-plate impact, for drawing it beside the bed's.
  std::function<void(const ImpactSample&)> on_reference_sample;
  BedCache* beds = nullptr;  ///< where beds are found or stored (a private cache when null)
  const BedRequest* bed_request = nullptr;
};

struct ImpactSummary {
  double peak_plate_force_N = 0.0;  ///< over every step, not only the written samples
  double peak_plate_force_time_s = 0.0;
  std::size_t beads = 0;
  double dt_s = 0.0;
  double critical_dt_s = 0.0;
  std::int64_t steps = 0;  ///< integrated steps (the analytic free flight takes none)
  int threads = 0;         ///< the engine threads of the impact's last step (dem/threads.h)
  double wall_time_s = 0.0;
  dem::DampingCalibration contact_damping;
  double bed_surface_m = 0.0;
  double free_flight_s = 0.0;          ///< time covered analytically
  double first_contact_time_s = -1.0;  ///< -1: the projectile never touched anything
  double impact_speed_m_s = 0.0;       ///< projectile speed at the end of the free flight
  double end_time_s = 0.0;
  std::string end_reason;

  BedSummary bed;
  PeakAnalysis peaks;             ///< Pa, Pb, P, dS, dt, load duration
  double crater_depth_m = 0.0;    ///< deepest point of the projectile below the bed surface
  double reference_peak_N = 0.0;  ///< Pa0: the same impact on the bare plate
  double reference_first_contact_time_s = -1.0;  ///< when it touched the plate (-1: not run)
  double lambda = 0.0;                           ///< buffer ratio (Pa0 - P) / Pa0
  double max_overlap_ratio = 0.0;  ///< largest overlap / smaller radius during the impact
  /// Where the stepped impact's computing time went (benchmarks; not in summary.json).
  dem::StageTimes stage_times;
};

/// Runs the scene. Throws SceneError for a bad scene, SimulationError when the run becomes
/// unstable and Cancelled when the cancel flag is raised. A bed is taken from control.beds.
ImpactSummary RunImpact(const Scene& scene, const RunControl& control = {});

/// The same, for a world already built from `scene` (so that a caller can check the scene
/// before creating any output).
ImpactSummary RunImpact(World world, const Scene& scene, const RunControl& control = {});

}  // namespace dembuf
