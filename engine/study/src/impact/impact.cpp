#include "dembuf/study/impact/impact.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <numbers>

#include "dembuf/core/time_step.h"
#include "dembuf/study/bed/bed.h"
#include "dembuf/study/scene/errors.h"
#include "dembuf/study/scene/part_fields.h"
#include "dembuf/study/scene/scene_fields.h"
#include "dembuf/study/scene/species.h"

namespace dembuf {

World BuildWorld(const Scene& scene, BedCache* cache, const BedRequest* request) {
  ValidateScene(scene);
  World world;
  if (!scene.bed.import.empty() || scene.bed.thickness_m > 0.0) {
    BedCache private_cache;
    PreparedBed bed =
        GetBed(scene, cache ? *cache : private_cache, request ? *request : BedRequest{});
    const std::string sha256 = BedContentSha256(bed);
    world.beads = std::move(bed.beads);
    world.history = std::move(bed.history);
    world.bed_surface_m = bed.surface_m;
    world.bed = BedSummary{bed.hash,
                           sha256,
                           bed.surface_m,
                           bed.solid_fraction,
                           bed.plate_force_N,
                           bed.wall_force_z_N,
                           bed.weight_N,
                           bed.note,
                           bed.warnings,
                           {},
                           {}};
    if (MixedBed(scene)) {
      for (int k = 0; k < SpeciesCount(scene); ++k)
        world.bed.species.push_back(SpeciesOf(scene, k).name);
      world.bed.layers = MeasureLayers(world.beads, scene);
    }
  }
  double min_radius = 0.5 * SmallestDiameter(scene);
  for (double r : world.beads.radius) min_radius = std::min(min_radius, r);
  ContactSetup setup = MakeContactSetup(scene, min_radius);
  world.params = setup.params;
  // The impact's own: the bed was prepared (and is shared) without it.
  SetBeadDamping(scene, world.params);
  world.contact_damping = setup.contact_damping;
  world.critical_dt_s = setup.critical_dt_s;

  if (scene.projectile.enabled) {
    dem::RigidSphere p;
    p.radius = 0.5 * scene.projectile.diameter_m;
    p.mass = scene.projectile.mass_kg;
    p.position =
        dem::Vec3(scene.projectile.offset_m, 0.0, world.bed_surface_m + scene.projectile.height_m);
    p.velocity = dem::Vec3(0.0, 0.0, -scene.projectile.speed_m_s);
    world.projectile = p;
  }
  return world;
}

namespace {

// Emits samples on the global grid t = k * interval, so that runs line up sample by sample.
// At most one sample a step: an interval below the step samples every step.
class SampleClock {
 public:
  explicit SampleClock(double interval) : m_interval(interval) {}
  bool Due(double t) const { return t >= m_next * m_interval * (1.0 - 1e-12); }
  /// Moves past every grid time up to t. The index is computed, not counted: a long flight
  /// at a tiny interval passes more grid times than any loop could count, and k is a double
  /// because it can pass 2^63 (it stays exact below 2^53).
  void Advance(double t) {
    if (!Due(t)) return;
    m_next = std::max(m_next, std::floor(t / (m_interval * (1.0 - 1e-12))));
    while (Due(t)) m_next = std::max(m_next + 1.0, std::nextafter(m_next, HUGE_VAL));
  }

 private:
  double m_interval;
  double m_next = 0.0;  ///< k of the next grid time
};

ImpactSample MakeSample(const dem::Simulation& sim) {
  const dem::StepObservables& o = sim.observables();
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
  return RunImpact(BuildWorld(scene, control.beds, control.bed_request), scene, control);
}

namespace {

ImpactSnapshot TakeSnapshot(const dem::Simulation& sim, const std::string& label,
                            bool with_contacts = true) {
  ImpactSnapshot snap;
  snap.label = label;
  snap.t_s = sim.time_s();
  snap.positions = sim.beads().position;
  snap.radii = sim.beads().radius;
  snap.species = sim.beads().species;
  snap.velocities = sim.beads().velocity;
  snap.forces = sim.beads().force;
  snap.ids = sim.BeadOrigins();
  snap.projectile = sim.projectile();
  if (with_contacts) snap.contacts = sim.Contacts();
  return snap;
}

// A snapshot's folder name: a time in milliseconds, to a microsecond at most, after a prefix
// ("t_57.2ms", "after_contact_0.5ms"); letters, digits, '.' and '_' only.
std::string TimeLabel(const char* prefix, double t) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%s%.6gms", prefix, std::round(t * 1e6) / 1e3);
  return buf;
}

// A snapshot due at `t_s`, and its label.
struct DueSnapshot {
  double t_s;
  std::string label;
  bool operator<(const DueSnapshot& other) const { return t_s < other.t_s; }
};

// One pass of the impact: the free flight jumped analytically, then the steps, each followed by
// the run's bookkeeping (peaks, the series, samples, snapshots, frames, progress) and the
// check of the automatic end. `peak_step` >= 0 asks for a "peak" snapshot at that step (known
// from an earlier pass of the same deterministic run).
class ImpactPass {
 public:
  ImpactPass(World world, const Scene& scene, const RunControl& control, std::int64_t peak_step);
  ImpactSummary Run(std::int64_t* found_peak_step);

 private:
  void FlyToBed();
  void StartImpact();
  void Record();
  /// Notes the first contact; the reason the run ends after this step, or nullptr.
  const char* EndReason();
  void Snapshot(ImpactSnapshot snap);
  void TakeFrame();
  bool FrameDue(double t) const {
    return m_animate && m_frames < kMaxAnimationFrames &&
           t >= m_series_start + m_frames * m_scene.output.animation_interval_s;
  }

  const Scene& m_scene;
  const RunControl& m_control;
  const std::int64_t m_peak_step;
  const double m_bed_surface_m;
  const std::chrono::steady_clock::time_point m_wall_start = std::chrono::steady_clock::now();
  ImpactSummary m_summary;
  dem::Simulation m_sim;
  double m_rest_force = 0.0;  ///< the resting load of the bed, felt during the free flight
  SampleClock m_clock;
  std::vector<DueSnapshot> m_snapshot_times;
  std::size_t m_next_snapshot = 0;
  double m_t_limit;  ///< time.end_s, or infinity (the automatic end)
  double m_t_end_estimate;

  // The impact's record. The steps of the impact window (time.impact_window_s from the first
  // contact, or from the start without one) go into the series the peaks are found in, so that
  // its memory is bounded however long the run goes on (time.end_s).
  ImpactSeries m_series;
  double m_series_start = 0.0;
  double m_peak = 0.0;
  double m_peak_time = 0.0;
  std::int64_t m_peak_at_step = 0;
  double m_crater = -std::numeric_limits<double>::infinity();
  double m_rest_since = -1.0;  ///< when the projectile last became slow
  // When the plate force last stood above the load duration's level: the peak analysis's
  // share of the peak's excess over the resting load, here on the raw force and peak (the
  // analysis smooths both; the E2 sweeps' durations came out the same to the bit).
  const PeakOptions m_peak_options;
  double m_loaded_until = 0.0;
  double m_slow_speed = 0.0;
  std::int64_t m_next_progress = 0;
  bool m_animate = false;  ///< animation frames, every output.animation_interval_s
  std::int64_t m_frames = 0;
};

ImpactPass::ImpactPass(World world, const Scene& scene, const RunControl& control,
                       std::int64_t peak_step)
    : m_scene(scene),
      m_control(control),
      m_peak_step(peak_step),
      m_bed_surface_m(world.bed_surface_m),
      m_sim(world.params, std::move(world.beads), world.projectile, world.history),
      m_clock(scene.time.output_interval_s),
      m_t_limit(scene.time.end_s > 0.0 ? scene.time.end_s
                                       : std::numeric_limits<double>::infinity()),
      m_t_end_estimate(m_t_limit) {
  m_summary.beads = m_sim.beads().size();
  m_summary.dt_s = world.params.dt_s;
  m_summary.critical_dt_s = world.critical_dt_s;
  m_summary.contact_damping = world.contact_damping;
  m_summary.bed_surface_m = world.bed_surface_m;
  m_summary.bed = world.bed;
  m_sim.RefreshForces();
  m_rest_force = m_sim.observables().plate_force_N;
  for (double t : scene.output.snapshot_times_s)
    m_snapshot_times.push_back({t, TimeLabel("t_", t)});
  std::stable_sort(m_snapshot_times.begin(), m_snapshot_times.end());
}

void ImpactPass::Snapshot(ImpactSnapshot snap) {
  if (m_summary.first_contact_time_s >= 0.0)
    snap.t_after_contact_s = snap.t_s - m_summary.first_contact_time_s;
  if (m_control.on_snapshot) m_control.on_snapshot(snap);
}

void ImpactPass::TakeFrame() {
  char label[32];
  std::snprintf(label, sizeof label, "frame_%05lld", static_cast<long long>(m_frames));
  m_control.on_frame(TakeSnapshot(m_sim, label, false));
  ++m_frames;
}

// Free flight: nothing but gravity acts on the projectile until it reaches the first bead
// below it (or the plate), and the resting bed does not change meanwhile. Jump there
// analytically, stopping a few steps short so that the first contact is integrated whole.
void ImpactPass::FlyToBed() {
  if (!m_sim.projectile()) return;
  const double g = m_scene.gravity_m_s2;
  dem::RigidSphere p = *m_sim.projectile();
  // The centre height at first contact: touching bead i at horizontal distance rho needs
  // z_c = z_i + sqrt((R + r_i)^2 - rho^2); the plate needs z_c = R.
  double contact_z = p.radius;
  const dem::ParticleState& beads = m_sim.beads();
  for (std::size_t i = 0; i < beads.size(); ++i) {
    const double reach = p.radius + beads.radius[i];
    const double dx = beads.position[i].x() - p.position.x();
    const double dy = beads.position[i].y() - p.position.y();
    const double rho2 = dx * dx + dy * dy;
    if (rho2 < reach * reach)
      contact_z = std::max(contact_z, beads.position[i].z() + std::sqrt(reach * reach - rho2));
  }
  const double speed_bound = std::abs(p.velocity.z()) + std::sqrt(2.0 * g * p.position.z());
  const double margin = 4.0 * speed_bound * m_sim.params().dt_s;
  double t_fly = FallTime(p.position.z(), p.velocity.z(), contact_z + margin, g);
  if (t_fly < 0.0) t_fly = std::isfinite(m_t_limit) ? m_t_limit : 0.0;
  t_fly = std::min(t_fly, m_t_limit);
  if (t_fly > 0.0) {
    const double z0 = p.position.z(), vz0 = p.velocity.z();
    const ImpactSnapshot at_rest =
        m_snapshot_times.empty() ? ImpactSnapshot{} : TakeSnapshot(m_sim, "");
    while (m_next_snapshot < m_snapshot_times.size() &&
           m_snapshot_times[m_next_snapshot].t_s <= t_fly) {
      const DueSnapshot& due = m_snapshot_times[m_next_snapshot++];
      const double t = due.t_s;
      ImpactSnapshot snap = at_rest;
      snap.label = due.label;
      snap.t_s = t;
      snap.projectile->position.z() = z0 + vz0 * t - 0.5 * g * t * t;
      snap.projectile->velocity.z() = vz0 - g * t;
      Snapshot(snap);
    }
    // The record starts after the flight: a resting bed under a falling sphere has nothing
    // to show, and its samples would cost up to a gigabyte (summary.free_flight_s says how
    // long it fell).
    m_clock.Advance(t_fly);
    p.position.z() = z0 + vz0 * t_fly - 0.5 * g * t_fly * t_fly;
    p.velocity.z() = vz0 - g * t_fly;
    m_sim.SetProjectile(p, t_fly);
    m_sim.RefreshForces();
    m_summary.free_flight_s = t_fly;
  }
  m_summary.impact_speed_m_s = m_sim.projectile()->velocity.norm();
  if (m_scene.time.end_s == 0.0) m_t_end_estimate = t_fly + m_scene.time.impact_window_s;
}

void ImpactPass::StartImpact() {
  m_series_start = m_sim.time_s();
  m_peak = m_sim.observables().plate_force_N;
  m_peak_time = m_sim.time_s();
  m_loaded_until = m_sim.time_s();
  m_slow_speed = 0.01 * std::max(m_summary.impact_speed_m_s, 1e-3);
  m_next_progress = m_control.steering.progress_every_steps;
  m_animate = m_control.on_frame && m_scene.output.animation_interval_s > 0.0;
  if (FrameDue(m_series_start)) TakeFrame();
}

// After a step: the peak, the series, the crater, samples, snapshots, frames and progress.
void ImpactPass::Record() {
  const dem::StepObservables& o = m_sim.observables();
  const double t = m_sim.time_s();
  m_summary.max_overlap_ratio = std::max(m_summary.max_overlap_ratio, o.max_overlap_ratio);
  if (o.plate_force_N > m_peak) {
    m_peak = o.plate_force_N;
    m_peak_time = t;
    m_peak_at_step = m_sim.steps();
  }
  if (o.plate_force_N - m_rest_force > m_peak_options.duration_fraction * (m_peak - m_rest_force))
    m_loaded_until = t;
  const double window_start =
      m_summary.first_contact_time_s >= 0.0 ? m_summary.first_contact_time_s : m_series_start;
  const bool in_window = t <= window_start + m_scene.time.impact_window_s;
  if (in_window) {
    m_series.t_s.push_back(t);
    m_series.plate_force_N.push_back(o.plate_force_N);
  }
  if (m_sim.projectile()) {
    const dem::RigidSphere& p = *m_sim.projectile();
    if (in_window) m_series.projectile_z_m.push_back(p.position.z());
    m_crater = std::max(m_crater, m_bed_surface_m - (p.position.z() - p.radius));
  }
  if (m_clock.Due(t)) {
    if (m_control.on_sample) m_control.on_sample(MakeSample(m_sim));
    m_clock.Advance(t);
  }
  while (m_next_snapshot < m_snapshot_times.size() && m_snapshot_times[m_next_snapshot].t_s <= t)
    Snapshot(TakeSnapshot(m_sim, m_snapshot_times[m_next_snapshot++].label));
  if (m_sim.steps() == m_peak_step) Snapshot(TakeSnapshot(m_sim, "peak"));
  if (FrameDue(t)) {
    TakeFrame();
    // A step longer than the interval skips the frames it jumped over.
    while (FrameDue(t)) ++m_frames;
  }
  // Every step: a step of a large bed takes milliseconds, a cancel must act within a second.
  if (m_control.steering.cancel && m_control.steering.cancel->load(std::memory_order_relaxed))
    throw Cancelled();
  if (m_sim.steps() >= m_next_progress) {
    m_next_progress += m_control.steering.progress_every_steps;
    if (m_control.steering.on_progress)
      m_control.steering.on_progress({t, m_t_end_estimate, m_sim.steps()});
  }
}

const char* ImpactPass::EndReason() {
  if (!m_sim.projectile()) return nullptr;
  const dem::StepObservables& o = m_sim.observables();
  const double t = m_sim.time_s();
  const dem::RigidSphere& p = *m_sim.projectile();
  if (m_summary.first_contact_time_s < 0.0) {
    if (o.projectile_contacts > 0) {
      m_summary.first_contact_time_s = t;
      // Snapshots counted from first contact join the schedule now that it is known.
      for (double after : m_scene.output.snapshot_after_contact_s)
        m_snapshot_times.push_back({t + after, TimeLabel("after_contact_", after)});
      std::stable_sort(m_snapshot_times.begin() + m_next_snapshot, m_snapshot_times.end());
    }
    return nullptr;
  }
  if (m_scene.time.end_s > 0.0) return nullptr;
  // Automatic end (time.end_s = 0): the projectile has bounced clear of the bed (rising,
  // touching nothing, its lowest point above the bed's original surface), or has rebounded
  // in its crater too fast to come back down to where it left the beads before the window
  // ends, or has been at rest for a millisecond, or the window has passed. After such a
  // rebound the plate carries only the bed settling back (in the E2 sweeps, at most 67 N
  // against peaks of 650 N and more: docs/accuracy-cost.md), and the deepest penetration is
  // behind; a slower rebound is followed through its landing. The run goes on until the
  // plate force has stayed below the load duration's level for the peak analysis's smoothing
  // width, so that the measured duration is not cut short, and while snapshots are due in
  // the window or animation frames are asked for.
  const double g = m_scene.gravity_m_s2;
  const double window_end = m_summary.first_contact_time_s + m_scene.time.impact_window_s;
  const bool rising_free = o.projectile_contacts == 0 && p.velocity.z() > 0.0;
  if (rising_free && p.position.z() - p.radius > m_bed_surface_m)
    return "projectile rebounded clear";
  const bool lands_after_window = g <= 0.0 || t + 2.0 * p.velocity.z() / g > window_end;
  const bool snapshot_due = m_next_snapshot < m_snapshot_times.size() &&
                            m_snapshot_times[m_next_snapshot].t_s <= window_end;
  const bool unloaded = t - m_loaded_until >= m_peak_options.smoothing_s;
  if (rising_free && lands_after_window && unloaded && !snapshot_due && !m_animate)
    return "projectile rebounded in its crater, too fast to fall back within "
           "time.impact_window_s";
  if (p.velocity.norm() < m_slow_speed) {
    if (m_rest_since < 0.0) m_rest_since = t;
    if (t - m_rest_since >= 1e-3) return "projectile at rest";
  } else {
    m_rest_since = -1.0;
  }
  if (t >= window_end) return "time.impact_window_s elapsed";
  return nullptr;
}

ImpactSummary ImpactPass::Run(std::int64_t* found_peak_step) {
  FlyToBed();
  StartImpact();
  while (true) {
    if (m_sim.time_s() >= m_t_limit) {
      m_summary.end_reason = "reached time.end_s";
      break;
    }
    if (m_control.steering.threads)
      m_sim.LendThreads(m_control.steering.threads->load(std::memory_order_relaxed));
    m_sim.Step();
    Record();
    if (const char* reason = EndReason()) {
      m_summary.end_reason = reason;
      break;
    }
  }
  if (m_control.steering.on_progress)
    m_control.steering.on_progress({m_sim.time_s(), m_sim.time_s(), m_sim.steps()});
  if (found_peak_step) *found_peak_step = m_peak_at_step;

  m_summary.peak_plate_force_N = m_peak;
  m_summary.peak_plate_force_time_s = m_peak_time;
  m_summary.peaks =
      AnalyzePeaks(m_series, {m_rest_force, m_bed_surface_m,
                              m_sim.projectile() ? m_sim.projectile()->radius : 0.0,
                              m_summary.beads > 0 ? BedMeanBead(m_scene).diameter_m : 0.0});
  m_summary.crater_depth_m = std::isfinite(m_crater) ? m_crater : 0.0;
  m_summary.steps = m_sim.steps();
  m_summary.threads = m_sim.threads();
  m_summary.stage_times = m_sim.stage_times();
  m_summary.end_time_s = m_sim.time_s();
  m_summary.wall_time_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - m_wall_start).count();
  return m_summary;
}

ImpactSummary RunPass(World world, const Scene& scene, const RunControl& control,
                      std::int64_t peak_step, std::int64_t* found_peak_step) {
  return ImpactPass(std::move(world), scene, control, peak_step).Run(found_peak_step);
}

}  // namespace

ImpactSummary RunImpact(World world, const Scene& scene, const RunControl& control) {
  ImpactSummary summary;
  if (scene.output.snapshot_at_peak) {
    // The run is deterministic: a first pass finds the step of the peak, the second takes the
    // snapshot there.
    RunControl quiet;  // cancelled and lent threads as the run, its progress not told twice
    quiet.steering.cancel = control.steering.cancel;
    quiet.steering.threads = control.steering.threads;
    std::int64_t peak_step = -1;
    RunPass(world, scene, quiet, -1, &peak_step);
    summary = RunPass(std::move(world), scene, control, peak_step, nullptr);
  } else {
    summary = RunPass(std::move(world), scene, control, -1, nullptr);
  }
  // The buffer ratio needs the same impact on the bare plate (a few hundred steps).
  if (summary.beads == 0 || !scene.projectile.enabled) {
    summary.reference_peak_N = summary.peaks.p_N;
  } else if (control.compute_reference) {
    Scene bare = scene;
    bare.bed.thickness_m = 0.0;
    bare.bed.import.clear();
    bare.output = OutputSpec{};
    // Its peak is the first impact: the bare run ends when the sphere bounces clear, however
    // long the scene's own run goes on (time.end_s).
    bare.time.end_s = 0.0;
    RunControl quiet;
    quiet.steering.cancel = control.steering.cancel;
    quiet.steering.threads = control.steering.threads;
    quiet.compute_reference = false;
    quiet.on_sample = control.on_reference_sample;
    const ImpactSummary reference = RunImpact(bare, quiet);
    summary.reference_peak_N = reference.peaks.p_N;
    summary.reference_first_contact_time_s = reference.first_contact_time_s;
  }
  if (summary.reference_peak_N > 0.0)
    summary.lambda = (summary.reference_peak_N - summary.peaks.p_N) / summary.reference_peak_N;
  return summary;
}

}  // namespace dembuf
