#include "dembuf/study/bed/bed.h"
#include "dembuf/study/bed/relaxation_cadence.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <numbers>
#include <random>
#include <sstream>
#include <unordered_map>

#include "dembuf/core/neighbor_list.h"
#include "dembuf/study/bed/bed_io.h"
#include "dembuf/study/scene/contact_setup.h"
#include "dembuf/study/scene/errors.h"
#include "dembuf/study/scene/scene_fields.h"
#include "dembuf/study/scene/species.h"
#include "dembuf/study/text/content_hash.h"

namespace dembuf {

namespace {

// ---- keys --------------------------------------------------------------------------------------

double SourceThickness(const Scene& scene) {
  return PlanSourceBed(scene).thickness_m;
}

// Whether the cut beds' local settling stops beads at their kinetic-energy peaks.
bool QuenchesCutBeads(const Scene& scene) {
  return scene.bed.local_settling && scene.bed.quench_cut_beads;
}

// The scene a bed's key is computed from: automatic values resolved (the source bed's
// thickness, the softening factor, a cut step or a friction-stage tolerance of 0) and a bed
// file named by its content, so that scenes which make the same bed share it. (An imported
// bed has no source bed: its source fields are keyed as given.)
Scene ResolvedForKeys(const Scene& scene) {
  Scene resolved = scene;
  if (!scene.bed.import.empty()) {
    resolved.bed.import = "sha256:" + ImportContentSha256(scene);
  } else {
    resolved.bed.source_thickness_m = SourceThickness(scene);
    resolved.bed.soft_settling = SoftSettlingFactor(scene);
  }
  resolved.bed.cut_alpha = CutRelaxationAlpha(scene);
  if (resolved.bed.friction_settle_tolerance == 0.0)
    resolved.bed.friction_settle_tolerance = scene.bed.settle_tolerance;
  return resolved;
}

// The versions of the procedures that make each stage (bed.h).
std::string SourceVersions(const Scene& scene) {
  // (A bed of one species is made as it was before species: its keys name no species version.)
  const bool species = MixedBed(scene) || scene.bed.import_types > 1;
  return "preparation v" + std::to_string(kBedPreparationVersion) + "\nlocal settling v" +
         std::to_string(kLocalSettlingVersion) + "\nsoft settling v" +
         std::to_string(kSoftSettlingVersion) + "\n" +
         (species ? "species v" + std::to_string(kSpeciesBedVersion) + "\n" : "");
}
std::string CutVersions() {
  return "cut bead quench v" + std::to_string(kCutBeadQuenchVersion) + "\nsurface cut v" +
         std::to_string(kSurfaceCutVersion) + "\ncut relaxation v" +
         std::to_string(kCutRelaxationVersion) + "\n";
}

// A stage's key text: its procedures' versions, then every field in use whose value shapes one
// of `stages` (the field table's column), exact number texts, in the table's order.
std::string KeyText(const Scene& resolved, std::initializer_list<Shapes> stages,
                    const std::string& versions) {
  std::string text = "dembuf bed\n" + versions;
  for (const SceneField& field : SceneFields())
    if (std::find(stages.begin(), stages.end(), field.shapes) != stages.end() &&
        (!field.in_use || field.in_use(resolved)))
      text += std::string(field.name) + "=" + FormatSceneField(resolved, field) + "\n";
  return text;
}

// ---- deterministic random numbers --------------------------------------------------------------

// Uniform doubles from the raw 64-bit engine (std::uniform_real_distribution is not specified
// bit-for-bit across standard libraries; beds must not depend on the library).
class Uniform {
 public:
  explicit Uniform(std::uint64_t seed) : m_engine(seed) {}
  double operator()(double lo, double hi) {
    return lo + (hi - lo) * static_cast<double>(m_engine() >> 11) * 0x1.0p-53;
  }

 private:
  std::mt19937_64 m_engine;
};

// ---- settling ----------------------------------------------------------------------------------

struct RestState {
  double kinetic_ratio;
  double balance_error;
  double weight;
};

RestState MeasureRest(const dem::Simulation& sim, double energy_scale) {
  const auto& b = sim.beads();
  double weight = 0.0;
  for (double m : b.mass) weight += m * sim.params().gravity_m_s2;
  const double kinetic = sim.BeadKineticEnergy() / std::max<std::size_t>(b.size(), 1);
  const auto& o = sim.observables();
  return {kinetic / energy_scale,
          weight > 0.0 ? std::abs(o.plate_force_N + o.wall_force_z_N - weight) / weight : 0.0,
          weight};
}

// ---- local settling --------------------------------------------------------------------------
//
// Once the bulk of a settling bed carries its weight, nearly all of its kinetic energy sits in
// a few beads near the surface that are still finding their place, while every bead is
// stepped. Local settling steps only their neighbourhood: the beads within kRegionReach of a
// moving bead are free, the beads a free bead can reach are held in place (inv_mass 0), and
// all others are stopped and left out. When a free bead has drifted kMaxDrift, or half of
// the moving beads have stopped, the region is chosen again around the beads moving then.
// Rest is still judged on the whole bed, after an interval in which every bead moves. The
// held and stopped beads are the approximation; its effect on the beds and on the outputs is
// measured in docs/accuracy-cost.md.

// Moving: a bead with more than this many times the rest tolerance's energy per bead. 1000
// (local settling version 1) left the thinnest beds' C0 up to 0.005 lower than settling as
// a whole; 300 up to 0.0012 lower, for 12% more time on the E2 sweep (docs/accuracy-cost.md).
constexpr double kMovingEnergy = 300.0;
// Local settling starts only when at most this share of the beads moves.
constexpr double kMaxMovingShare = 0.1;
// ...and goes on until the beads' kinetic energy is this fraction of the rest tolerance's.
constexpr double kLocalEnergyTarget = 0.5;
// Free: the beads whose centres lie within this many mean diameters of a moving bead.
constexpr double kRegionReach = 2.0;
// A region is chosen again when one of its free beads has moved this many mean diameters.
constexpr double kMaxDrift = 0.5;
// How often the bed and a region are checked, and when a region has stalled: Cadence
// (relaxation_cadence.h).

double TotalKinetic(const dem::ParticleState& b) {
  double kinetic = 0.0;
  for (std::size_t i = 0; i < b.size(); ++i) kinetic += b.KineticEnergy(i);
  return kinetic;
}

// The beads within `reach` (centre to centre) of a marked bead, the marked ones included.
std::vector<char> Near(const dem::ParticleState& b, const std::vector<char>& marked, double reach) {
  dem::Vec3 lo = b.position.front(), hi = b.position.front();
  for (const dem::Vec3& x : b.position) {
    lo = lo.cwiseMin(x);
    hi = hi.cwiseMax(x);
  }
  dem::detail::CellGrid grid;
  grid.Build(b.position, reach, lo, hi);
  std::vector<char> near = marked;
  const dem::Vec3 box = dem::Vec3::Constant(reach);
  for (std::size_t i = 0; i < b.size(); ++i) {
    if (!marked[i]) continue;
    grid.ForEachInBox(b.position[i] - box, b.position[i] + box, [&](std::uint32_t j) {
      if (!near[j] && (b.position[j] - b.position[i]).squaredNorm() <= reach * reach) near[j] = 1;
    });
  }
  return near;
}

bool IsWall(std::uint32_t other) {
  return other == dem::kPlate || other == dem::kSideWall;
}

// Kinetic damping's rule, for the whole bed or one bead: a kinetic energy that falls after
// rising has passed a maximum, and the body is stopped there (its energy then counts as 0).
class KineticPeak {
 public:
  explicit KineticPeak(double energy = 0.0) : m_last(energy) {}

  // Takes this step's kinetic energy; true when it has just passed a maximum.
  bool Passed(double energy) {
    const bool passed = m_rising && energy < m_last;
    if (passed) energy = 0.0;
    m_rising = energy > m_last;
    m_last = energy;
    return passed;
  }

 private:
  double m_last;
  bool m_rising = false;
};

// Kinetic damping bead by bead (bed.quench_cut_beads): after each step, a bead whose kinetic
// energy has passed a maximum is stopped. A bead rocking or rolling in its pocket passes its
// maximum at the bottom, where it then stays; a bead rolling or falling onto others keeps
// going until it meets them. (Stopping the whole bed at the maxima of its total energy, as
// bed.quench_cut_relaxation does, cannot catch beads that rock out of step with each other.)
class BeadQuench {
 public:
  // Follows the beads of `sim` through their renumbering, by BeadOrigins().
  explicit BeadQuench(const dem::Simulation& sim) : m_peaks(sim.beads().size()) {
    // ParticleState::KineticEnergy's two factors, computed once: its divisions, at every step
    // of every bead, took a tenth of a cut bed's relaxation. The same expressions, so the same
    // energies to the bit.
    const dem::ParticleState& b = sim.beads();
    const std::vector<std::uint32_t>& origin = sim.BeadOrigins();
    m_half_mass.resize(b.size());
    m_half_inertia.resize(b.size());
    for (std::size_t k = 0; k < b.size(); ++k) {
      m_half_mass[origin[k]] = 0.5 * b.mass[k];
      m_half_inertia[origin[k]] = 0.5 / b.InvInertia(k);
    }
  }

  void AfterStep(dem::Simulation& sim) {
    const dem::ParticleState& b = sim.beads();
    const std::vector<std::uint32_t>& origin = sim.BeadOrigins();
    m_stop.clear();
    for (std::size_t k = 0; k < b.size(); ++k) {
      const std::uint32_t o = origin[k];
      const double energy = m_half_mass[o] * b.velocity[k].squaredNorm() +
                            m_half_inertia[o] * b.angular_velocity[k].squaredNorm();
      if (m_peaks[o].Passed(energy)) m_stop.push_back(static_cast<std::uint32_t>(k));
    }
    sim.StopBeads(m_stop);
  }

 private:
  std::vector<KineticPeak> m_peaks;                 // by origin
  std::vector<double> m_half_mass, m_half_inertia;  // by origin
  std::vector<std::uint32_t> m_stop;
};

// One region: steps the free beads around `moving`, with the beads they can reach held, until
// a free bead has drifted kMaxDrift, half of the moving beads have stopped (kinetic energy
// below moving_energy), the region's kinetic energy is down to energy_limit, or it has stalled
// (kStallSteps), when its beads are stopped. With `quench_beads`, BeadQuench after each step.
// Writes the free beads' state and springs back into `beads` and `history`, and stops every
// other bead. Returns the steps taken. The region's clock starts at the bed's (`time_s`,
// `step`), so that an error in it names the bed's step and time.
std::int64_t SettleRegion(const dem::WorldParams& params, dem::ParticleState& beads,
                          std::vector<dem::ContactHistoryEntry>& history,
                          const std::vector<char>& moving, double moving_energy, double d_mean,
                          double d_max, double energy_limit, std::int64_t max_steps, double time_s,
                          std::int64_t step, bool quench_beads, const Cadence& cadence) {
  const std::vector<char> free_bead = Near(beads, moving, kRegionReach * d_mean);
  const auto moving_count = static_cast<std::size_t>(std::count(moving.begin(), moving.end(), 1));
  const double drift = kMaxDrift * d_mean;
  // A free bead stops within one step of moving `drift`, so it cannot touch a bead whose
  // centre is farther than d_max + 1.5 drift from where it started.
  const std::vector<char> in_region = Near(beads, free_bead, d_max + 1.5 * drift);

  dem::ParticleState region;
  std::vector<std::uint32_t> region_id(beads.size(), 0);
  std::vector<std::uint32_t> bed_id;
  for (std::size_t i = 0; i < beads.size(); ++i) {
    if (!in_region[i]) continue;
    region_id[i] = static_cast<std::uint32_t>(region.size());
    bed_id.push_back(static_cast<std::uint32_t>(i));
    region.AddCopy(beads, i);
    if (!free_bead[i]) {  // held: at rest, and neither contacts nor gravity move it
      region.velocity.back().setZero();
      region.angular_velocity.back().setZero();
      region.inv_mass.back() = 0.0;
    }
  }
  auto touches_free = [&](const dem::ContactHistoryEntry& h) {
    return free_bead[h.bead] || (!IsWall(h.other) && free_bead[h.other]);
  };
  std::vector<dem::ContactHistoryEntry> region_history, kept_history;
  for (const dem::ContactHistoryEntry& h : history) {
    if (in_region[h.bead] && (IsWall(h.other) || in_region[h.other]))
      region_history.push_back(
          {region_id[h.bead], IsWall(h.other) ? h.other : region_id[h.other], h.shear});
    if (!touches_free(h)) kept_history.push_back(h);  // springs the region cannot change
  }

  const std::vector<dem::Vec3> start = region.position;
  dem::Simulation sim(params, std::move(region), std::nullopt, region_history);
  sim.LendThreads(params.threads);  // the bed's threads, as many as the region's beads feed
  sim.SetClock(time_s, step);
  // Large regions are reordered in memory at list builds; origin maps back to region order.
  const std::vector<std::uint32_t>& origin = sim.BeadOrigins();
  std::int64_t steps = 0;
  bool stalled = false;
  double stall_reference = sim.BeadKineticEnergy();
  std::optional<BeadQuench> quench;
  if (quench_beads) quench.emplace(sim);
  try {
    while (steps < max_steps) {
      sim.Step();
      ++steps;
      if (quench) quench->AfterStep(sim);
      const dem::ParticleState& b = sim.beads();
      bool drifted = false;
      for (std::size_t k = 0; k < b.size() && !drifted; ++k)
        drifted = (b.position[k] - start[origin[k]]).squaredNorm() > drift * drift;
      if (drifted) break;
      if (steps % cadence.region_check == 0) {
        const double energy = sim.BeadKineticEnergy();
        if (energy <= energy_limit) break;
        std::size_t still = 0;
        for (std::size_t k = 0; k < b.size(); ++k) still += b.KineticEnergy(k) > moving_energy;
        if (2 * still <= moving_count) break;  // half have stopped: a smaller region will do
        if (steps % cadence.stall == 0) {
          stalled = energy > 0.5 * stall_reference;
          if (stalled) break;
          stall_reference = energy;
        }
      }
    }
  } catch (const dem::SimulationError& e) {
    throw dem::SimulationError(
        std::string("in local settling (bead numbers count the settling region's beads): ") +
            e.what(),
        e.step(), e.time_s());
  }

  const dem::ParticleState& b = sim.beads();
  for (std::size_t i = 0; i < beads.size(); ++i) {
    beads.velocity[i].setZero();
    beads.angular_velocity[i].setZero();
  }
  for (std::size_t k = 0; k < b.size(); ++k) {
    const std::uint32_t i = bed_id[origin[k]];
    if (!free_bead[i]) continue;
    beads.position[i] = b.position[k];
    if (stalled) continue;  // stopped, as the beads outside the region
    beads.velocity[i] = b.velocity[k];
    beads.angular_velocity[i] = b.angular_velocity[k];
  }
  for (dem::ContactHistoryEntry h : sim.ExportHistory()) {
    h.bead = bed_id[origin[h.bead]];
    if (!IsWall(h.other)) h.other = bed_id[origin[h.other]];
    if (touches_free(h)) kept_history.push_back(h);
  }
  history = std::move(kept_history);
  return steps;
}

// Local settling of `sim` when at most kMaxMovingShare of its beads move, until the beads'
// kinetic energy is down to kLocalEnergyTarget of the rest tolerance (`tolerance_energy` per
// bead). Returns the bed as a new simulation, its clock advanced by the steps taken, or
// nothing when too many beads move for it to pay. report(steps, kinetic energy) follows it.
// With `quench_beads`, the regions stop their beads at their kinetic-energy peaks (BeadQuench).
std::optional<dem::Simulation> SettleLocally(
    dem::Simulation& sim, double d_mean, double d_max, double tolerance_energy,
    std::int64_t max_steps, bool quench_beads, const Cadence& cadence,
    const std::function<void(std::int64_t, double)>& report) {
  dem::ParticleState beads = sim.beads();
  const std::size_t n = beads.size();
  const double moving_energy = kMovingEnergy * tolerance_energy;  // per bead
  std::vector<char> moving(n);
  auto count_moving = [&] {
    std::size_t count = 0;
    for (std::size_t i = 0; i < n; ++i) count += moving[i] = beads.KineticEnergy(i) > moving_energy;
    return count;
  };
  std::size_t count = count_moving();
  if (count == 0 || count > kMaxMovingShare * static_cast<double>(n)) return std::nullopt;
  const double energy_limit = kLocalEnergyTarget * tolerance_energy * static_cast<double>(n);
  std::vector<dem::ContactHistoryEntry> history = sim.ExportHistory();
  dem::WorldParams params = sim.params();
  std::int64_t steps = 0, reported = 0;
  while (count > 0 && steps < max_steps && TotalKinetic(beads) > energy_limit) {
    steps +=
        SettleRegion(params, beads, history, moving, moving_energy, d_mean, d_max, energy_limit,
                     max_steps - steps, sim.time_s() + static_cast<double>(steps) * params.dt_s,
                     sim.steps() + steps, quench_beads, cadence);
    count = count_moving();
    if (steps - reported >= 1000) {
      report(steps, TotalKinetic(beads));
      reported = steps;
    }
  }
  dem::Simulation settled(params, std::move(beads), std::nullopt, history);
  settled.SetClock(sim.time_s() + static_cast<double>(steps) * params.dt_s, sim.steps() + steps);
  return settled;
}

// How SettleToRest brings a bed to rest, besides stepping it.
struct Relaxation {
  // Kinetic damping first: whenever the beads' kinetic energy has passed a maximum, every
  // bead is stopped, until the maxima of a whole check interval stay below the tolerance.
  // Rest is judged only on intervals without quenching, so the criterion is the same.
  bool quench = false;
  // Local settling (above) whenever the bulk carries its weight but the bed is not yet at
  // rest; rest is judged on the whole bed, after an interval in which every bead moves.
  bool local = false;
  // In local settling, each bead stopped at its kinetic-energy peaks (BeadQuench).
  bool quench_beads = false;
  // The relaxation's step over the scene's (bed.cut_alpha over time.alpha): its checks come
  // that many times fewer steps apart, at the same simulated times (Cadence).
  double step_scale = 1.0;
};

// Integrates until the bed is at rest (see bed.h); returns the simulated time it took.
double SettleToRest(dem::Simulation& sim, const Scene& scene, const std::string& stage,
                    const BedRequest& request, double max_time, double tolerance,
                    const std::function<void(dem::Simulation&, double)>& before_step = {},
                    Relaxation relaxation = {}) {
  const MeanBead mean = BedMeanBead(scene);
  const double d_mean = mean.diameter_m;
  const double m_mean = mean.mass_kg;
  const double energy_scale = m_mean * scene.gravity_m_s2 * d_mean;
  const double t0 = sim.time_s();
  const Cadence cadence = Cadence::ForStepScale(relaxation.step_scale);
  bool quenching = relaxation.quench;
  KineticPeak peak(sim.BeadKineticEnergy());
  while (true) {
    if (request.threads) sim.LendThreads(request.threads->load(std::memory_order_relaxed));
    double interval_max = 0.0;  // largest kinetic energy of the beads in this interval [J]
    for (std::int64_t k = 0; k < cadence.rest_check; ++k) {
      // Every step: 200 steps of a large bed take seconds, a cancel must act within one.
      if (request.cancel && request.cancel->load(std::memory_order_relaxed)) throw Cancelled();
      if (before_step) before_step(sim, sim.time_s() - t0);
      sim.Step();
      if (!quenching) continue;
      const double energy = sim.BeadKineticEnergy();
      interval_max = std::max(interval_max, energy);
      if (peak.Passed(energy)) sim.ZeroBeadVelocities();
    }
    const double t = sim.time_s() - t0;
    const RestState rest = MeasureRest(sim, energy_scale);
    if (request.cancel && request.cancel->load(std::memory_order_relaxed)) throw Cancelled();
    if (request.on_progress)
      request.on_progress(
          {stage, t, max_time, sim.beads().size(), rest.kinetic_ratio, rest.balance_error});
    const bool ramp_done = !before_step || t >= scene.bed.friction_ramp_s;
    if (quenching) {
      const double beads = static_cast<double>(std::max<std::size_t>(sim.beads().size(), 1));
      quenching = interval_max / beads / energy_scale >= tolerance;
    } else if (ramp_done && rest.kinetic_ratio < tolerance && rest.balance_error < 0.01) {
      return t;
    } else if (relaxation.local && !before_step && rest.balance_error < 0.01) {
      const auto max_steps = static_cast<std::int64_t>((max_time - t) / sim.params().dt_s) + 1;
      auto report = [&](std::int64_t steps, double kinetic) {
        if (request.cancel && request.cancel->load(std::memory_order_relaxed)) throw Cancelled();
        if (request.on_progress)
          request.on_progress({stage + " (locally)", t + steps * sim.params().dt_s, max_time,
                               sim.beads().size(),
                               kinetic / static_cast<double>(sim.beads().size()) / energy_scale,
                               rest.balance_error});
      };
      if (auto settled =
              SettleLocally(sim, d_mean, LargestDiameter(scene), tolerance * energy_scale,
                            max_steps, relaxation.quench_beads, cadence, report))
        sim = std::move(*settled);
    }
    if (t > max_time) {
      std::ostringstream what;
      what << "the bed did not come to rest within bed.max_settle_s = " << max_time << " s ("
           << stage << " stage): kinetic energy per bead " << rest.kinetic_ratio
           << " m g d (tolerance " << tolerance << "), force balance error "
           << rest.balance_error * 100 << "% (tolerance 1%)";
      throw dem::SimulationError(what.str(), sim.steps(), sim.time_s());
    }
  }
}

PreparedBed Finish(dem::Simulation& sim, const Scene& scene, const std::string& hash,
                   const std::string& stage, double settle_time,
                   std::chrono::steady_clock::time_point wall_start) {
  PreparedBed bed;
  bed.beads = sim.beads();
  // A bed at rest: keep positions and springs, drop the residual jitter of the velocities so
  // that the resting state is exactly reproducible and the free flight sees a still bed.
  std::fill(bed.beads.velocity.begin(), bed.beads.velocity.end(), dem::Vec3::Zero());
  std::fill(bed.beads.angular_velocity.begin(), bed.beads.angular_velocity.end(),
            dem::Vec3::Zero());
  std::fill(bed.beads.force.begin(), bed.beads.force.end(), dem::Vec3::Zero());
  std::fill(bed.beads.torque.begin(), bed.beads.torque.end(), dem::Vec3::Zero());
  bed.history = sim.ExportHistory();
  bed.hash = hash;
  bed.stage = stage;
  bed.surface_m = MeasureSurface(bed.beads, scene.cylinder.radius_m);
  bed.solid_fraction = SolidFraction(bed.beads, scene.cylinder.radius_m, bed.surface_m);
  const MeanBead mean = BedMeanBead(scene);
  const RestState rest = MeasureRest(sim, mean.mass_kg * scene.gravity_m_s2 * mean.diameter_m);
  bed.weight_N = rest.weight;
  bed.kinetic_ratio = rest.kinetic_ratio;
  bed.plate_force_N = sim.observables().plate_force_N;
  bed.wall_force_z_N = sim.observables().wall_force_z_N;
  bed.settle_time_s = settle_time;
  bed.settle_steps = sim.steps();
  bed.wall_time_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  return bed;
}

// Every bead pair's friction (of every pair of species) to `friction`; the walls' as they are.
void SetBeadFriction(dem::WorldParams& params, double friction) {
  params.sphere_pair.friction = friction;
  for (dem::PairParams& pair : params.species.bead_pair) pair.friction = friction;
}

// A simulation of a bed with the scene's contact law and bead friction `friction` for every
// pair of beads (none: each pair's own).
dem::Simulation BedSimulation(const Scene& scene, dem::ParticleState beads,
                              std::vector<dem::ContactHistoryEntry> history,
                              std::optional<double> friction) {
  double min_radius = 0.5 * SmallestDiameter(scene);
  for (double r : beads.radius) min_radius = std::min(min_radius, r);
  ContactSetup setup = MakeContactSetup(scene, min_radius);
  if (friction) SetBeadFriction(setup.params, *friction);
  // Beds settle without rolling resistance, so that it leaves their cache keys alone: it only
  // dissipates, and a bed at rest stays at rest when the impact switches it on.
  setup.params.rolling_friction = 0.0;
  return dem::Simulation(setup.params, std::move(beads), std::nullopt, std::move(history));
}

dem::Simulation BedSimulation(const Scene& scene, const PreparedBed* from, dem::ParticleState beads,
                              std::optional<double> friction) {
  return BedSimulation(scene, std::move(beads),
                       from ? from->history : std::vector<dem::ContactHistoryEntry>{}, friction);
}

// ---- soft settling ---------------------------------------------------------------------------
//
// With bed.soft_settling = s, the source bed settles with the Young's modulus of its beads and
// walls divided by s: the time step is sqrt(s) times longer (eq. 6), the damping is calibrated
// to the same restitution, and the overlaps at rest are s^(2/3) times deeper. Then the true
// stiffness comes back: the overlaps push the beads apart by a few micrometres, and kinetic
// damping brings that to rest at once. A tangential spring's stiffness goes as
// E sqrt(overlap), so as s^(2/3) between the soft rest and the stiff one: its stretch shrinks
// by that much, so that it pulls as before once the overlaps have followed (unscaled, it would
// pull s times harder at the restoring, beyond Coulomb's limit, and every contact would slip).
//
// The cut beds relax at the true stiffness. A cut releases the elastic energy of the
// overburden, s^(2/3) times more of it in a soft bed, which tapped the thinnest beds 1.5%
// denser; softening a stiff bed drops every bead by its deeper overlap at once, which
// compacted the thick ones by 0.25% (docs/accuracy-cost.md).

// The scene a bed settles in: the scene itself, or its softened copy.
Scene SettlingScene(const Scene& scene) {
  const double softening = SoftSettlingFactor(scene);
  Scene soft = scene;
  soft.material.youngs_modulus_Pa /= softening;
  soft.walls.youngs_modulus_Pa /= softening;
  for (SpeciesSpec& species : soft.species) species.youngs_modulus_Pa /= softening;
  return soft;
}

// Settles `sim`, a bed built in SettlingScene(scene), to rest; with soft settling it then
// becomes the same bed with the scene's stiffness, relaxed to rest with kinetic damping.
// Returns the simulated time.
double SettleBed(dem::Simulation& sim, const Scene& scene, const std::string& stage,
                 const BedRequest& request) {
  const double softening = SoftSettlingFactor(scene);
  const bool soft = softening != 1.0;
  const double t = SettleToRest(sim, SettlingScene(scene), soft ? stage + " (soft)" : stage,
                                request, scene.bed.max_settle_s, scene.bed.settle_tolerance, {},
                                {.local = scene.bed.local_settling});
  if (!soft) return t;
  std::vector<dem::ContactHistoryEntry> history = sim.ExportHistory();
  for (dem::ContactHistoryEntry& h : history) h.shear *= std::pow(softening, -2.0 / 3.0);
  dem::Simulation stiff =
      BedSimulation(scene, sim.beads(), std::move(history), scene.bed.prep_friction);
  stiff.SetClock(sim.time_s(), sim.steps());
  sim = std::move(stiff);
  return t + SettleToRest(sim, scene, stage + " (stiffness restored)", request,
                          scene.bed.max_settle_s, scene.bed.settle_tolerance, {},
                          {.quench = true, .local = scene.bed.local_settling});
}

void InsertLayerBeads(const Scene& scene, const LayerPlan& layer, std::uint8_t layer_index,
                      Uniform& uniform, dem::ParticleState& beads, const BedRequest& request);

// A source bed of layers (LayerSpec), poured in turn from the plate up: each layer's beads
// inserted above the layers below, the whole bed settled (SettleBed), and each layer but the
// last cut at its top and relaxed as a cut bed is (at time.alpha's step), so that the next one lies
// on a surface where the layer was asked to end. The last layer is poured to the source's thickness
// and cut to H with the bed (PrepareCut), as a bed of one layer is.
PreparedBed PrepareLayeredSource(const Scene& scene, const std::string& hash,
                                 const BedRequest& request) {
  const auto wall_start = std::chrono::steady_clock::now();
  const SourcePlan plan = PlanSourceBed(scene);
  Uniform uniform(static_cast<std::uint64_t>(scene.bed.seed));
  dem::ParticleState beads;
  std::vector<dem::ContactHistoryEntry> history;
  std::optional<dem::Simulation> sim;
  double t = 0.0, insert_time = 0.0;
  for (std::size_t layer = 0; layer < plan.layers.size(); ++layer) {
    const auto insert_start = std::chrono::steady_clock::now();
    InsertLayerBeads(scene, plan.layers[layer], static_cast<std::uint8_t>(layer), uniform, beads,
                     request);
    insert_time +=
        std::chrono::duration<double>(std::chrono::steady_clock::now() - insert_start).count();
    const double clock = sim ? sim->time_s() : 0.0;
    const std::int64_t steps = sim ? sim->steps() : 0;
    sim.emplace(BedSimulation(SettlingScene(scene), std::move(beads), std::move(history),
                              scene.bed.prep_friction));
    sim->SetClock(clock, steps);
    const std::string name = "settling layer " + std::to_string(layer + 1);
    t += SettleBed(*sim, scene, name, request);
    if (layer + 1 < plan.layers.size()) {
      const std::vector<bool> keep =
          CutMask(sim->beads(), scene.cylinder.radius_m, plan.layers[layer].top_m, scene.bed.cut);
      sim->RemoveBeads([&](std::size_t i) { return keep[i]; });
      t += SettleToRest(*sim, scene, "relaxing layer " + std::to_string(layer + 1) + "'s cut",
                        request, scene.bed.max_settle_s, scene.bed.settle_tolerance, {},
                        {.quench = scene.bed.quench_cut_relaxation,
                         .local = scene.bed.local_settling,
                         .quench_beads = QuenchesCutBeads(scene)});
    }
    beads = sim->beads();
    std::fill(beads.velocity.begin(), beads.velocity.end(), dem::Vec3::Zero());
    std::fill(beads.angular_velocity.begin(), beads.angular_velocity.end(), dem::Vec3::Zero());
    history = sim->ExportHistory();
  }
  PreparedBed bed = Finish(*sim, scene, hash, "source", t, wall_start);
  bed.insert_time_s = insert_time;
  if (bed.surface_m < scene.bed.thickness_m)
    throw dem::SimulationError("the settled bed is only " + std::to_string(bed.surface_m) +
                                   " m thick, less than bed.thickness_m",
                               sim->steps(), sim->time_s());
  return bed;
}

PreparedBed PrepareSource(const Scene& scene, const std::string& hash, const BedRequest& request) {
  if (LayerCount(scene) > 1) return PrepareLayeredSource(scene, hash, request);
  const auto wall_start = std::chrono::steady_clock::now();
  dem::ParticleState inserted = InsertSourceBeads(scene, request);
  const double insert_time =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  dem::Simulation sim =
      BedSimulation(SettlingScene(scene), std::move(inserted), {}, scene.bed.prep_friction);
  const double t = SettleBed(sim, scene, "settling", request);
  PreparedBed bed = Finish(sim, scene, hash, "source", t, wall_start);
  bed.insert_time_s = insert_time;
  if (bed.surface_m < scene.bed.thickness_m)
    throw dem::SimulationError("the settled bed is only " + std::to_string(bed.surface_m) +
                                   " m thick, less than bed.thickness_m",
                               sim.steps(), sim.time_s());
  return bed;
}

PreparedBed PrepareCut(const Scene& scene, const PreparedBed& source, const std::string& hash,
                       const BedRequest& request) {
  const auto wall_start = std::chrono::steady_clock::now();
  Scene relaxing = scene;  // the scene, with the relaxation's own step
  relaxing.time.alpha = CutRelaxationAlpha(scene);
  dem::Simulation sim = BedSimulation(relaxing, &source, source.beads, scene.bed.prep_friction);
  const std::vector<bool> keep =
      CutMask(source.beads, scene.cylinder.radius_m, scene.bed.thickness_m, scene.bed.cut);
  sim.RemoveBeads([&](std::size_t i) { return keep[i]; });
  const double t = SettleToRest(sim, scene, "relaxing the cut bed", request, scene.bed.max_settle_s,
                                scene.bed.settle_tolerance, {},
                                {.quench = scene.bed.quench_cut_relaxation,
                                 .local = scene.bed.local_settling,
                                 .quench_beads = QuenchesCutBeads(scene),
                                 .step_scale = relaxing.time.alpha / scene.time.alpha});
  return Finish(sim, scene, hash, "cut", t, wall_start);
}

PreparedBed PrepareFriction(const Scene& scene, const PreparedBed& cut, const std::string& hash,
                            const BedRequest& request) {
  const auto wall_start = std::chrono::steady_clock::now();
  dem::Simulation sim = BedSimulation(scene, &cut, cut.beads, scene.bed.prep_friction);
  const double mu0 = scene.bed.prep_friction;
  const double ramp = scene.bed.friction_ramp_s;
  // The study's friction of every pair.
  const dem::WorldParams target = MakeContactSetup(scene, 0.5 * SmallestDiameter(scene)).params;
  // Linear in time from the preparation friction to the study's, each pair to its own, then
  // relax.
  auto before_step = [&](dem::Simulation& s, double t) {
    const double f = ramp > 0.0 ? std::min(t / ramp, 1.0) : 1.0;
    dem::WorldParams now = s.params();
    now.sphere_pair.friction = mu0 + f * (target.sphere_pair.friction - mu0);
    for (std::size_t k = 0; k < now.species.bead_pair.size(); ++k)
      now.species.bead_pair[k].friction = mu0 + f * (target.species.bead_pair[k].friction - mu0);
    s.SetPairConstants(now);
  };
  const double tolerance = scene.bed.friction_settle_tolerance > 0.0
                               ? scene.bed.friction_settle_tolerance
                               : scene.bed.settle_tolerance;
  const double t = SettleToRest(sim, scene, "changing friction", request,
                                ramp + scene.bed.max_settle_s, tolerance, before_step);
  return Finish(sim, scene, hash, "friction", t, wall_start);
}

PreparedBed PrepareImport(const Scene& scene, const std::string& hash, const BedRequest& request) {
  const auto wall_start = std::chrono::steady_clock::now();
  ImportedBed imported = ReadTextBed(scene.bed.import, scene);
  const std::string report = imported.Describe();
  const std::vector<std::string> warnings = imported.warnings;
  // The study's friction, each pair its own (an imported bed has no friction stage).
  dem::Simulation sim = BedSimulation(scene, nullptr, std::move(imported.beads), std::nullopt);
  const double t = SettleToRest(sim, scene, "relaxing the imported bed", request,
                                scene.bed.max_settle_s, scene.bed.settle_tolerance);
  PreparedBed bed = Finish(sim, scene, hash, "import", t, wall_start);
  bed.note = report;
  bed.warnings = warnings;
  return bed;
}

PreparedBed FindOrMake(BedCache& cache, const std::string& hash, const std::string& stage,
                       const std::function<PreparedBed()>& make) {
  return cache.FindOrMake(hash, stage, make);
}

}  // namespace

BedStageKeys BedKeys(const Scene& scene) {
  const Scene r = ResolvedForKeys(scene);
  using enum Shapes;
  BedStageKeys keys;
  if (!scene.bed.import.empty()) {
    keys.import = ContentHash(
        KeyText(r, {kSourceBed, kFrictionBed, kImportedBed}, SourceVersions(r) + "imported\n"));
    return keys;
  }
  // A source bed of layers is cut between them (PrepareLayeredSource): what shapes every cut
  // shapes it too.
  keys.source =
      LayerCount(r) > 1
          ? ContentHash(KeyText(r, {kSourceBed, kEveryCut}, SourceVersions(r) + CutVersions()))
          : ContentHash(KeyText(r, {kSourceBed}, SourceVersions(r)));
  keys.cut =
      ContentHash(KeyText(r, {kSourceBed, kEveryCut, kCutBed}, SourceVersions(r) + CutVersions()));
  keys.friction = ContentHash(KeyText(r, {kSourceBed, kEveryCut, kCutBed, kFrictionBed},
                                      SourceVersions(r) + CutVersions()));
  return keys;
}

std::string BedSourceHash(const Scene& scene) {
  if (!scene.bed.import.empty() || scene.bed.thickness_m <= 0.0) return "";
  return BedKeys(scene).source;
}

std::string BedHash(const Scene& scene) {
  const BedStageKeys k = BedKeys(scene);
  if (!scene.bed.import.empty()) return k.import;
  return NeedsFrictionStage(scene) ? k.friction : k.cut;
}

std::vector<BedStage> BedStagesOf(const Scene& scene) {
  if (!scene.bed.import.empty()) return {{"import", BedKeys(scene).import}};
  if (scene.bed.thickness_m <= 0.0) return {};
  const BedStageKeys k = BedKeys(scene);
  std::vector<BedStage> stages = {{"source", k.source}, {"cut", k.cut}};
  if (NeedsFrictionStage(scene)) stages.push_back({"friction", k.friction});
  return stages;
}

BedNeeds BedNeedsOf(const Scene& scene) {
  const bool has_bed = scene.bed.thickness_m > 0.0 || !scene.bed.import.empty();
  return {BedSourceHash(scene), has_bed ? BedHash(scene) : ""};
}

bool WaitsForBed(const BedNeeds& needs, const std::vector<BedNeeds>& running, BedCache& beds) {
  for (const BedNeeds& other : running) {
    if (!needs.source_hash.empty() && other.source_hash == needs.source_hash &&
        !beds.Contains(needs.source_hash))
      return true;
    if (!needs.bed_hash.empty() && other.bed_hash == needs.bed_hash &&
        !beds.Contains(needs.bed_hash))
      return true;
  }
  return false;
}

PreparedBed GetBed(const Scene& scene, BedCache& cache, const BedRequest& request) {
  ValidateScene(scene);
  const BedStageKeys k = BedKeys(scene);
  if (!scene.bed.import.empty())
    return FindOrMake(cache, k.import, "import",
                      [&] { return PrepareImport(scene, k.import, request); });
  auto cut = [&] {
    return FindOrMake(cache, k.cut, "cut", [&] {
      const PreparedBed source = FindOrMake(
          cache, k.source, "source", [&] { return PrepareSource(scene, k.source, request); });
      return PrepareCut(scene, source, k.cut, request);
    });
  };
  if (!NeedsFrictionStage(scene)) return cut();
  return FindOrMake(cache, k.friction, "friction",
                    [&] { return PrepareFriction(scene, cut(), k.friction, request); });
}

PreparedBed GetSourceBed(const Scene& scene, BedCache& cache, const BedRequest& request) {
  ValidateScene(scene);
  if (!scene.bed.import.empty() || scene.bed.thickness_m <= 0.0)
    throw SceneError("bed.thickness_m", "this scene's bed is not cut from a source bed");
  const BedStageKeys k = BedKeys(scene);
  return FindOrMake(cache, k.source, "source",
                    [&] { return PrepareSource(scene, k.source, request); });
}

void CheckPreparedBed(const PreparedBed& bed, const Scene& scene) {
  auto FormatNumber = [](double v) {
    char text[32];
    std::snprintf(text, sizeof text, "%.6g", v);
    return std::string(text);
  };
  auto fail = [&](const std::string& why) {
    throw SceneError("bed", bed.stage + " bed " + bed.hash + ": " + why);
  };
  const std::vector<BedStage> stages = BedStagesOf(scene);
  if (!scene.bed.import.empty())
    fail("its scene imports a bed file; send the file with the job instead");
  const auto stage = std::find_if(stages.begin(), stages.end(), [&](const BedStage& s) {
    return s.hash == bed.hash && s.stage == bed.stage;
  });
  if (stage == stages.end()) {
    std::string names;
    for (const BedStage& s : stages) names += (names.empty() ? "" : ", ") + s.stage + " " + s.hash;
    fail("it is none of the scene's beds (" + (names.empty() ? "none" : names) +
         "): prepared for another scene, or by another version of dembuf");
  }
  const dem::ParticleState& b = bed.beads;
  if (b.size() == 0) fail("it holds no beads");
  const double R = scene.cylinder.radius_m;
  const double r_max = 0.5 * LargestDiameter(scene);
  constexpr double kRounding = 1e-9;  // relative: the doubles of another machine's sums
  const int species = SpeciesCount(scene);
  if (b.species.size() != b.size() || b.layer.size() != b.size())
    fail("it gives no species or layer for some of its beads");
  double weight = 0.0;
  for (std::size_t i = 0; i < b.size(); ++i) {
    const double r = b.radius[i];
    const dem::Vec3& x = b.position[i];
    const std::string bead = "bead " + std::to_string(i + 1);
    if (b.species[i] >= species || !HasBeadsOf(scene, b.species[i]))
      fail(bead + " is of species " + std::to_string(b.species[i] + 1) +
           ", which the scene's bed does not mix in");
    if (b.layer[i] >= LayerCount(scene) || LayerFraction(scene, b.layer[i], b.species[i]) <= 0.0)
      fail(bead + " is of species " + std::to_string(b.species[i] + 1) + " in layer " +
           std::to_string(b.layer[i] + 1) + ", which the scene's layers do not mix so");
    const SpeciesMaterial m = SpeciesOf(scene, b.species[i]);
    const double r_lo = 0.5 * m.diameter_min_m, r_hi = 0.5 * m.diameter_max_m;
    if (!x.allFinite() || !std::isfinite(r) || r < r_lo * (1 - kRounding) ||
        r > r_hi * (1 + kRounding))
      fail(bead + " has radius " + FormatNumber(r) + " m, outside the scene's " +
           FormatNumber(r_lo) + " to " + FormatNumber(r_hi) + " m for " + m.name +
           " (or a position not a number)");
    const double mass = m.density_kg_m3 * 4.0 / 3.0 * std::numbers::pi * r * r * r;
    if (std::abs(b.mass[i] - mass) > kRounding * mass)
      fail(bead + " weighs " + FormatNumber(b.mass[i]) + " kg, not the scene's density's " +
           FormatNumber(mass) + " kg for " + m.name);
    // A resting contact overlaps by at most kMaxRestingOverlap of a radius (bed_io.h).
    const double slack = kMaxRestingOverlap * r;
    if (x.z() < r - slack || std::hypot(x.x(), x.y()) > R - r + slack)
      fail(bead + " at (" + FormatNumber(x.x()) + ", " + FormatNumber(x.y()) + ", " +
           FormatNumber(x.z()) + ") m lies outside the container");
    if (b.velocity[i] != dem::Vec3::Zero() || b.angular_velocity[i] != dem::Vec3::Zero())
      fail(bead + " moves: a prepared bed is stored at rest");
    weight += b.mass[i] * scene.gravity_m_s2;
  }
  const double surface = MeasureSurface(b, R);
  if (std::abs(surface - bed.surface_m) > kRounding * surface)
    fail("its beads' surface is at " + FormatNumber(surface) + " m, not the " +
         FormatNumber(bed.surface_m) + " m it states");
  if (std::abs(weight - bed.weight_N) > kRounding * weight)
    fail("its beads weigh " + FormatNumber(weight) + " N, not the " + FormatNumber(bed.weight_N) +
         " N it states");
  const double H = scene.bed.thickness_m;
  if (bed.stage == "source" ? surface < H : std::abs(surface - H) > 2.0 * r_max)
    fail("its surface is at " + FormatNumber(surface) +
         " m, where the scene's bed.thickness_m is " + FormatNumber(H) + " m");
}

double MeasureSurface(const dem::ParticleState& beads, double cylinder_radius_m) {
  if (beads.size() == 0) return 0.0;
  const double d_max = 2.0 * *std::max_element(beads.radius.begin(), beads.radius.end());
  const double cell = 2.0 * d_max;
  const double inner = std::max(cylinder_radius_m - d_max, 0.5 * cell);
  const int n = static_cast<int>(std::ceil(cylinder_radius_m / cell));
  std::vector<double> top((2 * n) * (2 * n), -1.0);
  for (std::size_t i = 0; i < beads.size(); ++i) {
    const dem::Vec3& x = beads.position[i];
    const int cx = std::clamp(static_cast<int>(std::floor(x.x() / cell)) + n, 0, 2 * n - 1);
    const int cy = std::clamp(static_cast<int>(std::floor(x.y() / cell)) + n, 0, 2 * n - 1);
    double& t = top[cy * 2 * n + cx];
    t = std::max(t, x.z() + beads.radius[i]);
  }
  double sum = 0.0;
  int cells = 0;
  for (int cy = 0; cy < 2 * n; ++cy)
    for (int cx = 0; cx < 2 * n; ++cx) {
      const double x = (cx - n + 0.5) * cell, y = (cy - n + 0.5) * cell;
      if (x * x + y * y > inner * inner) continue;
      sum += std::max(top[cy * 2 * n + cx], 0.0);  // an empty cell is bare plate
      ++cells;
    }
  return cells ? sum / cells : 0.0;
}

// Keeps the beads whose centre lies below the height that puts the measured surface nearest
// to H (bed.cut = "surface"), or those whose top is below H (bed.cut = "tops").
//
// The measured surface rises with the cut height in steps, one at each bead centre the cut
// passes. Secant steps from a radius below H end within tolerance in a few iterations when H
// falls on a step's tread. When they circle a riser instead (small beds, where one bead moves
// a cell's top by a radius), bisection between the highest cut found below H and the lowest
// found above narrows the riser to one bead, and the side nearer to H is kept.
std::vector<bool> CutMask(const dem::ParticleState& beads, double cylinder_radius, double thickness,
                          const std::string& convention) {
  const std::size_t n = beads.size();
  if (convention == "tops") {
    std::vector<bool> keep(n);
    for (std::size_t i = 0; i < n; ++i)
      keep[i] = beads.position[i].z() + beads.radius[i] <= thickness;
    return keep;
  }
  auto mask = [&](double cut) {  // the beads whose centre is below `cut`
    std::vector<bool> keep(n);
    for (std::size_t i = 0; i < n; ++i) keep[i] = beads.position[i].z() < cut;
    return keep;
  };
  auto surface_at = [&](double cut) {
    dem::ParticleState kept;
    for (std::size_t i = 0; i < n; ++i)
      if (beads.position[i].z() < cut) kept.Add(beads.position[i], beads.radius[i], 1.0);
    return MeasureSurface(kept, cylinder_radius);
  };
  if (n == 0) return {};
  double mean_r = 0.0, lowest = beads.position[0].z(), highest = lowest;
  for (std::size_t i = 0; i < n; ++i) {
    mean_r += beads.radius[i] / n;
    lowest = std::min(lowest, beads.position[i].z());
    highest = std::max(highest, beads.position[i].z());
  }
  // The cuts known to leave the surface at or below H and above it, with their surfaces.
  double below = lowest, below_surface = 0.0;  // keeps no bead
  double above = std::nextafter(highest, HUGE_VAL), above_surface = surface_at(above);  // all
  if (above_surface <= thickness) return mask(above);  // the source is not deeper than H
  double cut = thickness - mean_r;
  for (int iteration = 0; iteration < 12; ++iteration) {
    const double surface = surface_at(cut);
    if (std::abs(surface - thickness) < 1e-3 * mean_r) return mask(cut);
    if (surface <= thickness && cut > below) {
      below = cut;
      below_surface = surface;
    } else if (surface > thickness && cut < above) {
      above = cut;
      above_surface = surface;
    }
    cut += thickness - surface;
  }
  auto centres_between = [&] {
    std::size_t count = 0;
    for (std::size_t i = 0; i < n; ++i)
      count += below <= beads.position[i].z() && beads.position[i].z() < above;
    return count;
  };
  // Each halving at least halves the interval; 200 reach any two distinct heights.
  for (int halving = 0; halving < 200 && centres_between() > 1; ++halving) {
    const double middle = 0.5 * (below + above);
    const double surface = surface_at(middle);
    if (surface <= thickness) {
      below = middle;
      below_surface = surface;
    } else {
      above = middle;
      above_surface = surface;
    }
  }
  return mask(thickness - below_surface <= above_surface - thickness ? below : above);
}

std::vector<LayerSummary> MeasureLayers(const dem::ParticleState& beads, const Scene& scene) {
  const int layers = LayerCount(scene), species = SpeciesCount(scene);
  const double R = scene.cylinder.radius_m;
  std::vector<LayerSummary> out(static_cast<std::size_t>(layers));
  double bottom = 0.0;
  for (int k = 0; k < layers; ++k) {
    LayerSummary& layer = out[k];
    layer.beads.assign(static_cast<std::size_t>(species), 0);
    dem::ParticleState up_to_here, own;
    for (std::size_t i = 0; i < beads.size(); ++i) {
      const int of = i < beads.layer.size() ? beads.layer[i] : 0;
      if (of > k) continue;
      up_to_here.AddCopy(beads, i);
      if (of < k) continue;
      own.AddCopy(beads, i);
      const int kind = i < beads.species.size() ? beads.species[i] : 0;
      if (kind < species) ++layer.beads[kind];
    }
    layer.bottom_m = bottom;
    layer.top_m = MeasureSurface(up_to_here, R);
    layer.asked_top_m = k + 1 < layers ? LayerBottom(scene, k + 1) : scene.bed.thickness_m;
    layer.solid_fraction = SolidFraction(own, R, layer.top_m - layer.bottom_m);
    bottom = layer.top_m;
  }
  return out;
}

double SolidFraction(const dem::ParticleState& beads, double cylinder_radius_m,
                     double thickness_m) {
  if (thickness_m <= 0.0) return 0.0;
  double volume = 0.0;
  for (double r : beads.radius) volume += 4.0 / 3.0 * std::numbers::pi * r * r * r;
  return volume / (std::numbers::pi * cylinder_radius_m * cylinder_radius_m * thickness_m);
}

// ---- insertion ---------------------------------------------------------------------------------

namespace {

// Picks the species of a layer's next bead: the one furthest below its share of the volume
// inserted so far (the first on a tie), so that the layer's mixture is its fractions to within a
// bead whatever the draw. It draws no random number: a layer of one species takes the draws it
// always took.
class SpeciesPicker {
 public:
  explicit SpeciesPicker(const std::array<double, kMaxSpecies>& fraction) : m_fraction(fraction) {}
  int Next() const {
    int best = -1;
    double best_deficit = 0.0;
    for (int k = 0; k < kMaxSpecies; ++k) {
      if (m_fraction[k] <= 0.0) continue;
      const double deficit = m_fraction[k] * m_total - m_volume[k];
      if (best < 0 || deficit > best_deficit) {
        best = k;
        best_deficit = deficit;
      }
    }
    return best;
  }
  void Inserted(int k, double volume) {
    m_volume[k] += volume;
    m_total += volume;
  }

 private:
  std::array<double, kMaxSpecies> m_fraction;
  std::array<double, kMaxSpecies> m_volume{};
  double m_total = 0.0;
};

// Adds a layer's beads (LayerPlan) to `beads` at random positions in its loose column, each
// clear of the others and of the beads already there, each marked as of layer `layer_index`.
void InsertLayerBeads(const Scene& scene, const LayerPlan& layer, std::uint8_t layer_index,
                      Uniform& uniform, dem::ParticleState& beads, const BedRequest& request) {
  if (layer.column_top_m > scene.cylinder.height_m)
    throw SceneError("bed.source_thickness_m",
                     "a bed this thick needs a loose column of " +
                         std::to_string(layer.column_top_m) +
                         " m to settle from, higher than cylinder.height_m");
  const double R = scene.cylinder.radius_m;
  if (!(layer.beads + static_cast<double>(beads.size()) <= kMaxBeads))
    throw SceneError("beads.diameter_min_m",
                     "the source bed would hold more than " + std::to_string(kMaxBeads) +
                         " beads, more than a simulation can number; use larger beads or a "
                         "thinner bed");
  const auto count = static_cast<std::size_t>(layer.beads);
  const double bottom = layer.bottom_m;
  double column_top = layer.column_top_m;
  std::array<SpeciesMaterial, kMaxSpecies> species;
  for (int k = 0; k < kMaxSpecies; ++k) species[k] = SpeciesOf(scene, k);
  SpeciesPicker picker(layer.fraction);

  const double cell = LargestDiameter(scene);
  auto key = [&](int x, int y, int z) {
    return (static_cast<std::int64_t>(z) << 32) ^ (static_cast<std::int64_t>(y + 32768) << 16) ^
           (x + 32768);
  };
  auto cell_of = [&](double v) { return static_cast<int>(std::floor(v / cell)); };
  std::unordered_map<std::int64_t, std::vector<std::uint32_t>> grid;
  for (std::uint32_t j = 0; j < beads.size(); ++j) {
    const dem::Vec3& x = beads.position[j];
    grid[key(cell_of(x.x()), cell_of(x.y()), cell_of(x.z()))].push_back(j);
  }
  for (std::size_t n = 0; n < count; ++n) {
    // A large bed takes a while to insert: look at the cancel flag now and then.
    if (n % 4096 == 0 && request.cancel && request.cancel->load(std::memory_order_relaxed))
      throw Cancelled();
    const int kind = picker.Next();
    const SpeciesMaterial& m = species[kind];
    const double r = 0.5 * uniform(m.diameter_min_m, m.diameter_max_m);
    for (int attempt = 0;; ++attempt) {
      if (attempt == 2000) {  // crowded: give the column more room
        column_top = bottom + (column_top - bottom) * 1.1;
        if (column_top > scene.cylinder.height_m)
          throw SceneError("bed.source_thickness_m",
                           "cannot fit the beads for this thickness into the cylinder");
        attempt = 0;
      }
      const double reach = R - r;
      const double x = uniform(-reach, reach), y = uniform(-reach, reach);
      if (x * x + y * y > reach * reach) continue;
      const double z = uniform(bottom + r, column_top - r);
      const dem::Vec3 p(x, y, z);
      const int cx = cell_of(x), cy = cell_of(y), cz = cell_of(z);
      bool free = true;
      for (int dz = -1; dz <= 1 && free; ++dz)
        for (int dy = -1; dy <= 1 && free; ++dy)
          for (int dx = -1; dx <= 1 && free; ++dx) {
            auto it = grid.find(key(cx + dx, cy + dy, cz + dz));
            if (it == grid.end()) continue;
            for (std::uint32_t j : it->second) {
              const double reach_j = r + beads.radius[j];
              if ((beads.position[j] - p).squaredNorm() < reach_j * reach_j) {
                free = false;
                break;
              }
            }
          }
      if (!free) continue;
      grid[key(cx, cy, cz)].push_back(static_cast<std::uint32_t>(beads.size()));
      beads.Add(p, r, m.density_kg_m3, static_cast<dem::Species>(kind), layer_index);
      picker.Inserted(kind, 4.0 / 3.0 * std::numbers::pi * r * r * r);
      break;
    }
  }
}

}  // namespace

// A loose column of solid fraction about 0.3 above the plate.
dem::ParticleState InsertSourceBeads(const Scene& scene, const BedRequest& request) {
  const SourcePlan plan = PlanSourceBed(scene);
  if (plan.layers.size() != 1)
    throw SceneError("layer1.thickness_m",
                     "a bed of layers is poured layer by layer, not from one loose column");
  Uniform uniform(static_cast<std::uint64_t>(scene.bed.seed));
  dem::ParticleState beads;
  InsertLayerBeads(scene, plan.layers[0], 0, uniform, beads, request);
  return beads;
}

}  // namespace dembuf
