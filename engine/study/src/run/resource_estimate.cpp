#include "dembuf/study/run/resource_estimate.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <sstream>

#include "dembuf/core/simulation.h"
#include "dembuf/core/time_step.h"
#include "dembuf/study/bed/bed.h"
#include "dembuf/study/bed/bed_io.h"
#include "dembuf/study/files/lammps_frames.h"
#include "dembuf/study/files/vtk_files.h"
#include "dembuf/study/impact/impact.h"
#include "dembuf/study/scene/bed_plan.h"
#include "dembuf/study/scene/contact_setup.h"
#include "dembuf/study/scene/errors.h"
#include "dembuf/study/scene/species.h"

namespace dembuf {

namespace {

// Measured costs (tests/bench/dembuf_bench.cpp, one thread of the 2-core machine of the
// figures of docs/performance.md): a bead-step of a bed at rest (settling: many contacts) and of an
// impact, and a step's fixed cost (a lone projectile on the plate: 12.8 million steps in
// 17.8 s). Two threads ran a 30,000-bead bed 1.8 to 2.0 times as fast as one.
constexpr double kSettleSecondsPerBeadStep = 60e-9;
constexpr double kImpactSecondsPerBeadStep = 47e-9;
constexpr double kSecondsPerStep = 1.4e-6;
constexpr double kParallelEfficiency = 0.9;

// Memory: a simulation's resident bytes per bead (352 to 391 measured on 100,000 beads, its
// lists and springs included); a bed kept in a cache (15 doubles and about three springs);
// insertion's grid; and the process itself.
constexpr double kSimulationBytesPerBead = 400;
constexpr double kCachedBytesPerBead = 220;
constexpr double kInsertionBytesPerBead = 40;
constexpr double kProcessBytes = 64e6;
// The neighbour grid spans the container up to the beads' top, in cells of a bead's diameter
// and the list skin (engine/core/src/bead_lists.cpp): 4 bytes a cell kept, 4 more while it
// is built. Nothing for beads of millimetres; gigabytes for beads of micrometres.
constexpr double kGridBytesPerCell = 8;
// Per step of the impact window: time, force and height, and the peak finder's three arrays.
constexpr double kSeriesBytesPerStep = 48;
// A snapshot in memory: positions and radii, and about three contacts a bead.
constexpr double kSnapshotBytesPerBead = 32 + 3 * 88;

// Files: a CSV row at most; summary.json and the plots; a snapshot's files per bead (VTK
// points and lines, contacts.csv's rows) and per 1 cm plate cell.
constexpr double kBytesPerSample = 90;
constexpr double kRunFileBytes = 1e6;
constexpr double kSnapshotFileBytesPerBead = 750;
constexpr double kSnapshotFileBytesPerCell = 30;
// An animation frame: its beads (vtk_files.h) and its line in frames.pvd.
constexpr double kPvdBytesPerEntry = 100;

// A settled bed's solid fraction is 0.60 to 0.64 (docs/reproduction.md); the upper end
// counts the beads of a cut bed.
constexpr double kSettledSolidFraction = 0.64;
// Simulated time a bed takes to come to rest after its beads are in place: a cut bed or a
// friction change relaxes in 0.07 to 1.7 s (docs/accuracy-cost.md; the E2 bed of 2 cm in
// 0.16 s), a source bed about 0.2 s after its loose column has fallen (E2: 0.43 s in all,
// 0.21 s of it the fall).
constexpr double kTypicalRelaxation_s = 0.3;
constexpr double kTypicalSourceRest_s = 0.2;
// A cut or a friction change relaxes with local settling, which steps only the beads near
// those still moving: the E2 cut of 2 cm (6,251 beads, source of 5 cm cached) took 6.0 s of
// CPU where every bead stepped for kTypicalRelaxation_s would take 56 s.
constexpr double kLocalSettlingShare = 0.11;
// An automatic end comes well before the end of the impact window for the paper's impacts
// (the projectile rebounds or stops within about 10 ms).
constexpr double kTypicalImpact_s = 0.01;

std::string Short(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g", v);
  return buf;
}

// An animation frame's bytes per bead, in the formats the scene asks for.
double FrameBytesPerBead(const Scene& scene) {
  const std::string& format = scene.output.frame_format;
  return (format != "lammps" ? report::kVtpBytesPerBead : 0.0) +
         (format != "vtp" ? report::kDumpBytesPerBead : 0.0);
}

bool Skipped(const StageEstimate& stage, const std::vector<std::string>& skip) {
  return std::find(skip.begin(), skip.end(), stage.hash) != skip.end();
}

}  // namespace

std::string HumanBytes(double bytes) {
  const char* const units[] = {"B", "kB", "MB", "GB", "TB", "PB"};
  int u = 0;
  while (bytes >= 1000 && u < 5) {
    bytes /= 1000;
    ++u;
  }
  char buf[48];
  std::snprintf(buf, sizeof buf, "%.3g %s", bytes, units[u]);
  return buf;
}

std::string HumanSeconds(double s) {
  char buf[48];
  if (s < 90)
    std::snprintf(buf, sizeof buf, "%.2g s", s);
  else if (s < 5400)
    std::snprintf(buf, sizeof buf, "%.2g min", s / 60);
  else if (s < 2 * 86400)
    std::snprintf(buf, sizeof buf, "%.2g h", s / 3600);
  else
    std::snprintf(buf, sizeof buf, "%.3g days", s / 86400);
  return buf;
}

double ResourceEstimate::MaxBeads() const {
  double beads = impact_beads;
  for (const StageEstimate& s : stages) beads = std::max(beads, s.beads);
  return beads;
}

double ResourceEstimate::StepsMax(const std::vector<std::string>& skip) const {
  double steps = impact_steps_max;
  for (const StageEstimate& s : stages)
    if (!Skipped(s, skip)) steps += s.steps_max;
  return steps;
}

double ResourceEstimate::BeadStepsMax(const std::vector<std::string>& skip) const {
  double work = impact_steps_max * impact_beads;
  for (const StageEstimate& s : stages)
    if (!Skipped(s, skip)) work += s.steps_max * s.beads;
  return work;
}

namespace {

// Seconds for `steps` steps of `beads` beads at `seconds_per_bead_step` on `threads` threads.
double StepSeconds(double steps, double beads, double seconds_per_bead_step, int threads) {
  const double speedup = beads >= static_cast<double>(dem::kParallelMinBeads) && threads > 1
                             ? kParallelEfficiency * threads
                             : 1.0;
  return steps * (kSecondsPerStep + beads * seconds_per_bead_step / speedup);
}

}  // namespace

double ResourceEstimate::StageSeconds(const StageEstimate& s, int threads) const {
  const double steps = std::min(s.typical_settle_s / (dt_s * s.step_factor), s.steps_max);
  const double share = s.stage == "source" || s.stage == "import" ? 1.0 : kLocalSettlingShare;
  return StepSeconds(steps, share * s.beads, kSettleSecondsPerBeadStep, threads);
}

double ResourceEstimate::ImpactSeconds(int threads) const {
  const double steps = std::min(impact_steps_max, kTypicalImpact_s / dt_s);
  return StepSeconds(steps, impact_beads, kImpactSecondsPerBeadStep, threads);
}

double ResourceEstimate::PredictedSeconds(int threads, const std::vector<std::string>& skip) const {
  double seconds = ImpactSeconds(threads);
  for (const StageEstimate& s : stages)
    if (!Skipped(s, skip)) seconds += StageSeconds(s, threads);
  return seconds;
}

namespace {

// The cells of the neighbour grid over a container of radius `container_m` with beads up to
// `top_m`, as RebuildLists builds it.
double GridCells(double container_m, double top_m, double min_radius, double max_radius) {
  const double cell = 2.0 * max_radius + dem::WorldParams{}.skin_fraction * 2.0 * min_radius;
  const double margin = 2.0 * max_radius;
  const double across = std::max(1.0, std::ceil((2.0 * container_m + 2.0 * margin) / cell));
  const double up = std::max(1.0, std::ceil((top_m + 2.0 * margin) / cell));
  return across * across * up;
}

// The bytes of a run's output files and its memory at most, from its steps, samples,
// snapshots and frames: an impact of `one_pass` steps, a bed up to `bed_top_m`.
void EstimateBytes(const Scene& scene, double one_pass, double bed_top_m, double min_radius,
                   double max_radius, ResourceEstimate& e) {
  const bool projectile = scene.projectile.enabled;
  const double plate_cells = std::pow(std::ceil(2.0 * scene.cylinder.radius_m / 0.01), 2);
  e.output_bytes_max =
      kRunFileBytes + e.samples_max * kBytesPerSample +
      e.snapshots *
          (e.impact_beads * kSnapshotFileBytesPerBead + plate_cells * kSnapshotFileBytesPerCell) +
      e.animation_frames * ((e.impact_beads + 1) * FrameBytesPerBead(scene) + kPvdBytesPerEntry);
  // The bare-plate impact's samples (plate_force_bare.csv), over one impact window at most.
  if (e.impact_beads > 0 && projectile)
    e.output_bytes_max +=
        (std::floor(scene.time.impact_window_s / scene.time.output_interval_s) + 2) *
        kBytesPerSample;

  double settling = 0.0, cached = 0.0;
  for (const StageEstimate& s : e.stages) {
    const double insertion = s.stage == "source" ? kInsertionBytesPerBead : 0.0;
    settling = std::max(settling, s.beads * (kSimulationBytesPerBead + insertion));
    cached += s.beads * kCachedBytesPerBead;
  }
  const double window_steps =
      std::min(one_pass, std::ceil(scene.time.impact_window_s / e.dt_s) + 10);
  const double impact =
      e.impact_beads * kSimulationBytesPerBead +
      (scene.output.snapshot_at_peak ? e.impact_beads * kCachedBytesPerBead : 0.0) +
      window_steps * kSeriesBytesPerStep +
      (e.snapshots + e.animation_frames > 0 ? e.impact_beads * kSnapshotBytesPerBead : 0.0);
  const double grid = e.MaxBeads() > 0
                          ? kGridBytesPerCell * GridCells(scene.cylinder.radius_m, bed_top_m,
                                                          min_radius, max_radius)
                          : 0.0;
  e.memory_bytes_max = kProcessBytes + std::max(settling, impact) + cached + grid;
}

}  // namespace

ResourceEstimate EstimateResources(const Scene& scene) {
  ResourceEstimate e;
  const double area = std::numbers::pi * scene.cylinder.radius_m * scene.cylinder.radius_m;
  const double max_settle_s = scene.bed.max_settle_s;
  double min_radius = 0.5 * SmallestDiameter(scene);
  double max_radius = 0.5 * LargestDiameter(scene);
  const SourcePlan plan = PlanSourceBed(scene);
  double bed_top_m = std::max(plan.column_top_m, scene.bed.thickness_m);
  const std::vector<BedStage> stages = BedStagesOf(scene);
  if (!scene.bed.import.empty()) {
    const ImportedBedSize imported = MeasureImportedBed(scene);
    if (imported.beads > 0) {
      min_radius = imported.min_radius_m;
      max_radius = imported.max_radius_m;
    }
    bed_top_m = imported.top_m;
    e.impact_beads = imported.beads;
  }
  e.dt_s = scene.time.alpha * CriticalTimeStepOf(scene, min_radius);
  // A settling stage is checked for rest every 200 steps at the impact's step (at most).
  auto settle_steps = [&](double seconds) { return std::ceil(seconds / e.dt_s) + 200; };

  // The cut bed: each layer's share of H at the settled packing, in its mean bead.
  double cut_beads = 0.0;
  for (const LayerPlan& layer : plan.layers) {
    const double top = &layer == &plan.layers.back() ? scene.bed.thickness_m : layer.top_m;
    cut_beads += kSettledSolidFraction * area * std::max(top - layer.bottom_m, 0.0) /
                 layer.mean_bead_volume_m3;
  }
  cut_beads = std::ceil(cut_beads);
  for (const BedStage& stage : stages) {
    StageEstimate s{stage.stage, stage.hash};
    s.steps_max = settle_steps(max_settle_s);
    s.typical_settle_s = kTypicalRelaxation_s;
    if (stage.stage == "source") {
      s.beads = plan.beads;
      // A bed of layers settles each layer (soft and then at the true stiffness, or once),
      // and cuts and relaxes each but the last: each a settling of its own, up to max_settle_s.
      const auto layers = static_cast<double>(plan.layers.size());
      const double settlings = SoftSettlingFactor(scene) != 1.0 ? 2.0 : 1.0;
      if (layers > 1) s.steps_max = settle_steps(max_settle_s) * ((settlings + 1.0) * layers - 1.0);
      // Soft settling: beads softer by a factor s take steps sqrt(s) times as long (Hertz's
      // contact time goes as E^(-2/5), the critical step as E^(-1/2): the bound is kept).
      s.step_factor = std::sqrt(SoftSettlingFactor(scene));
      // Each layer falls from its column and comes to rest; those below the top are cut and
      // relaxed too.
      s.typical_settle_s = 0.0;
      for (const LayerPlan& layer : plan.layers) {
        const double fall =
            FallTime(layer.column_top_m - layer.bottom_m, 0.0, 0.0, scene.gravity_m_s2);
        s.typical_settle_s += fall >= 0.0 ? fall + kTypicalSourceRest_s : max_settle_s;
        if (&layer != &plan.layers.back()) s.typical_settle_s += kTypicalRelaxation_s;
      }
    } else if (stage.stage == "import") {
      s.beads = e.impact_beads;
    } else {
      s.beads = cut_beads;
      e.impact_beads = cut_beads;
      // The cut relaxes with its own step; steps_max keeps the impact's, an upper bound.
      if (stage.stage == "cut") s.step_factor = CutRelaxationAlpha(scene) / scene.time.alpha;
    }
    if (stage.stage == "friction") {
      s.steps_max = settle_steps(scene.bed.friction_ramp_s + max_settle_s);
      s.typical_settle_s += scene.bed.friction_ramp_s;
    }
    s.typical_settle_s = std::min(s.typical_settle_s, max_settle_s);
    e.stages.push_back(s);
  }

  // The impact: from the end of the free flight to time.end_s, or to the end of the impact
  // window after the first contact (a few steps after the flight).
  const ProjectileSpec& p = scene.projectile;
  const double end = scene.time.end_s;
  if (p.enabled) {
    const double flight = FallTime(scene.bed.thickness_m + p.height_m, -p.speed_m_s,
                                   scene.bed.thickness_m + 0.5 * p.diameter_m, scene.gravity_m_s2);
    e.flight_time_s = flight < 0.0 ? end : flight;
    if (end > 0.0) e.flight_time_s = std::min(e.flight_time_s, end);
  }
  const double duration =
      end > 0.0 ? end - e.flight_time_s : scene.time.impact_window_s + 10.0 * e.dt_s;
  const double one_pass = std::ceil(duration / e.dt_s) + 10;
  // A snapshot at the peak runs the impact twice; lambda needs the bare plate's impact.
  e.impact_steps_max = one_pass * (scene.output.snapshot_at_peak ? 2 : 1);
  if (e.impact_beads > 0 && p.enabled)
    e.impact_steps_max += std::ceil(scene.time.impact_window_s / e.dt_s) + 10;
  e.samples_max = std::min(std::floor(duration / scene.time.output_interval_s) + 2, one_pass + 1);
  e.snapshots = static_cast<double>(scene.output.snapshot_times_s.size() +
                                    scene.output.snapshot_after_contact_s.size() +
                                    (scene.output.snapshot_at_peak ? 1 : 0));

  if (scene.output.animation_interval_s > 0.0)
    e.animation_frames =
        std::min(std::floor(duration / scene.output.animation_interval_s) + 1, kMaxAnimationFrames);

  EstimateBytes(scene, one_pass, bed_top_m, min_radius, max_radius, e);
  return e;
}

void CheckResources(const ResourceEstimate& e, const ResourceLimits& limits, const Scene& scene,
                    const std::string& who) {
  auto over = [](double value, double limit) { return limit > 0.0 && !(value <= limit); };
  const bool bed = !e.stages.empty();
  const std::string thinner =
      scene.bed.import.empty()
          ? "larger beads (beads.diameter_min_m), a thinner bed (bed.thickness_m, "
            "bed.source_thickness_m) or a narrower cylinder (cylinder.radius_m)"
          : "a smaller bed file";
  // The field most to blame for a count of steps: the fixed end, the settling time or the
  // impact window; the time step's factor scales them all.
  const std::string steps_field = scene.time.end_s > 0.0 ? "time.end_s"
                                  : bed && e.StepsMax() > 2 * e.impact_steps_max
                                      ? "bed.max_settle_s"
                                      : "time.impact_window_s";
  const double beads = e.MaxBeads();
  if (over(beads, limits.beads))
    throw ResourceError(
        scene.beads.diameter_min_m < 1e-3 ? "beads.diameter_min_m" : "bed.thickness_m",
        "the bed would hold about " + Short(beads) + " beads; " + who + " limit is " +
            Short(limits.beads) + " per run: use " + thinner);
  if (over(e.StepsMax(), limits.steps))
    throw ResourceError(steps_field, "the run would take up to " + Short(e.StepsMax()) +
                                         " time steps of " + Short(e.dt_s) + " s; " + who +
                                         " limit is " + Short(limits.steps) +
                                         " per run: shorten it or raise time.alpha");
  if (over(e.BeadStepsMax(), limits.bead_steps))
    throw ResourceError(bed ? "bed.thickness_m" : steps_field,
                        "the run would take up to " + Short(e.BeadStepsMax()) +
                            " bead-steps (beads times time steps, settling at most " +
                            Short(scene.bed.max_settle_s) + " s per stage); " + who + " limit is " +
                            Short(limits.bead_steps) + " per run: use " + thinner +
                            ", or a shorter run");
  if (over(e.samples_max, limits.samples))
    throw ResourceError("time.output_interval_s",
                        "the run would write up to " + Short(e.samples_max) + " force samples; " +
                            who + " limit is " + Short(limits.samples) +
                            " per run: raise the interval or shorten the run");
  if (over(e.output_bytes_max, limits.output_bytes)) {
    // The field of the largest part of the files.
    const double samples = e.samples_max * kBytesPerSample;
    const double frames = e.animation_frames * (e.impact_beads + 1) * FrameBytesPerBead(scene);
    const double snapshots = e.snapshots > 0 ? e.output_bytes_max - samples - frames : 0.0;
    const char* field = frames >= std::max(samples, snapshots) ? "output.animation_interval_s"
                        : snapshots > samples                  ? "output.snapshot_times_s"
                                                               : "time.output_interval_s";
    throw ResourceError(field, "the run would write up to " + HumanBytes(e.output_bytes_max) +
                                   "; " + who + " limit is " + HumanBytes(limits.output_bytes) +
                                   ": fewer snapshots, frames or samples");
  }
  if (over(e.memory_bytes_max, limits.memory_bytes))
    throw ResourceError(bed ? "bed.thickness_m" : "time.impact_window_s",
                        "the run would need up to " + HumanBytes(e.memory_bytes_max) +
                            " of memory; " + who + " limit is " + HumanBytes(limits.memory_bytes) +
                            ": use " + thinner);
}

std::string DescribeEstimate(const ResourceEstimate& e, const std::vector<std::string>& cached,
                             int threads) {
  std::ostringstream out;
  out << "time step " << Short(e.dt_s) << " s\n";
  for (const StageEstimate& s : e.stages) {
    const bool ready = std::find(cached.begin(), cached.end(), s.hash) != cached.end();
    out << "bed " << s.stage << " " << s.hash << ": ";
    if (ready)
      out << "in the cache\n";
    else
      out << "to prepare, about " << Short(s.beads) << " beads, typically "
          << Short(s.typical_settle_s) << " s of settling, at most " << Short(s.steps_max)
          << " steps\n";
  }
  out << "impact: " << Short(e.impact_beads) << " beads";
  if (e.flight_time_s > 0) out << ", free flight " << Short(e.flight_time_s) << " s (computed)";
  out << ", at most " << Short(e.impact_steps_max) << " steps\n";
  out << "at most " << Short(e.StepsMax(cached)) << " time steps, " << Short(e.BeadStepsMax(cached))
      << " bead-steps\n";
  out << "output: at most " << Short(e.samples_max) << " force samples";
  if (e.snapshots > 0) out << ", " << Short(e.snapshots) << " snapshots";
  if (e.animation_frames > 0) out << ", " << Short(e.animation_frames) << " animation frames";
  out << ", " << HumanBytes(e.output_bytes_max) << " of files\n";
  out << "memory: at most " << HumanBytes(e.memory_bytes_max) << "\n";
  out << "predicted wall time: about " << HumanSeconds(e.PredictedSeconds(threads, cached))
      << " on " << threads << (threads == 1 ? " thread" : " threads")
      << " (measured costs per bead-step, typical settling)\n";
  return out.str();
}

}  // namespace dembuf
