// The DEM integrator: beads, an optional projectile and the container, advanced with velocity
// Verlet. This is the engine's core; impact.h builds one from a Scene and runs an impact.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

#include "dembuf/core/contact_law.h"
#include "dembuf/core/particles.h"

namespace dembuf::dem {

/// Beds of at least this many beads are kept in cell order and processed in parallel blocks;
/// smaller systems (two-body tests, a few hundred beads) keep their order and run on one
/// thread whatever SetThreads says.
inline constexpr std::size_t kParallelMinBeads = 1024;

/// Constants of the world, fixed for a run. The physics parts' parameters are among them
/// (parts/parts.h lists the parts; each one's On says which of these call for it).
struct WorldParams {
  Container container;
  PairParams sphere_pair;  ///< bead-bead and projectile-bead
  PairParams sphere_wall;  ///< bead and projectile against plate and side wall
  /// Beads of several species (parts/species_pairs.h): every kind of pair's constants. A world
  /// of one species (count 1, the default) uses sphere_pair and sphere_wall alone.
  SpeciesTable species;
  /// Rolling resistance mu_r of every contact (parts/rolling_resistance.h); 0: none.
  double rolling_friction = 0.0;
  double gravity_m_s2 = 9.81;
  BeadDamping bead_damping;  ///< parts/bead_damping.h; off by default
  double dt_s = 1e-6;
  /// Neighbor-list skin as a fraction of the smallest bead diameter. Wide, because the force
  /// pass checks only the pairs within a much smaller gap (PairList's near part): a wider skin
  /// costs only the list builds it spares. 0.4 was the fastest of 0.2 to 0.6 on the impact of
  /// a settled bed (docs/performance.md).
  double skin_fraction = 0.4;
  /// Threads for the force and integration loops; 0: all the machine's cores. Results do not
  /// depend on this number.
  int threads = 0;
};

/// What the plate, the wall and the projectile felt in the last step.
struct StepObservables {
  double plate_force_N = 0.0;   ///< total normal force on the plate (beads + projectile)
  double wall_force_z_N = 0.0;  ///< vertical force of the side wall on beads + projectile
  Vec3 projectile_force_N = Vec3::Zero();  ///< contact force on the projectile
  int projectile_contacts = 0;
  int bead_contacts = 0;  ///< bead-bead contacts
  /// Largest overlap / smaller radius of any contact in the step. Hertz theory assumes small
  /// strains; values above 0.1 mean the scene is beyond what the model describes well.
  double max_overlap_ratio = 0.0;
};

/// The tangential history of one contact, for saving a bed exactly. `other` is a bead, the
/// plate or the side wall.
struct ContactHistoryEntry {
  BodyId bead;
  BodyId other;
  Vec3 shear;
};

/// One contact at an instant (for force networks, plate maps and force statistics).
struct ContactSnapshot {
  BodyId a;    ///< a bead, or the projectile
  BodyId b;    ///< a bead, the plate or the side wall
  Vec3 point;  ///< contact point (middle of the overlap)
  Vec3 force;  ///< force on body a (normal + tangential)
  double normal_N;
};

/// Where a simulation's computing time went, summed over its steps (seconds of wall clock;
/// read by benchmarks to name the next bottleneck).
struct StageTimes {
  double integration_s = 0.0;  ///< kick and drift of the beads and the projectile
  double neighbours_s = 0.0;   ///< list builds and sorts, and the checks whether one is due
  double forces_s = 0.0;       ///< the contact force pass
  std::int64_t list_builds = 0;
  std::int64_t pair_sorts = 0;  ///< sorts of the pair list's far part between builds
};

/// Energy bookkeeping (for tests and stability checks).
struct EnergyBreakdown {
  double kinetic_J = 0.0;    ///< translational + rotational
  double potential_J = 0.0;  ///< m g z
  double elastic_J = 0.0;    ///< stored in the normal and tangential springs
  double Total() const { return kinetic_J + potential_J + elastic_J; }
};

class Simulation {
 public:
  /// `history` restores the tangential springs of a saved bed.
  Simulation(const WorldParams& params, ParticleState beads, std::optional<RigidSphere> projectile,
             const std::vector<ContactHistoryEntry>& history = {});
  ~Simulation();
  Simulation(Simulation&&) noexcept;
  Simulation& operator=(Simulation&&) noexcept;

  /// Advances one time step. Throws SimulationError when the state becomes unphysical
  /// (non-finite values, overlaps beyond a third of a radius, a bead outside the container).
  void Step();

  double time_s() const { return m_time_s; }
  std::int64_t steps() const { return m_steps; }
  const WorldParams& params() const { return m_params; }
  /// The beads at time_s() (completing the last step's closing half kick if it is pending).
  const ParticleState& beads() const {
    CompleteKick();
    return m_beads;
  }
  const std::optional<RigidSphere>& projectile() const { return m_projectile; }
  const StepObservables& observables() const { return m_observables; }

  /// Computes the forces and observables of the current state without advancing (e.g. the
  /// resting load of a bed on the plate).
  void RefreshForces();

  /// Moves the projectile (e.g. after an analytic free flight) and sets the clock.
  void SetProjectile(const RigidSphere& projectile, double time_s);

  EnergyBreakdown Energy() const;

  /// Kinetic energy of the beads only (translation + rotation), cheap.
  double BeadKineticEnergy() const;

  /// Changes the friction coefficients (e.g. a slow ramp after settling) of a world of one
  /// species (one of several throws std::logic_error: SetPairConstants).
  void SetFriction(double sphere_pair, double sphere_wall);
  /// Changes the constants of every kind of pair (sphere_pair, sphere_wall and species) to
  /// those of `from`, which must have as many species (a friction ramp of several species).
  void SetPairConstants(const WorldParams& from);

  /// Stops every bead (velocities and spins to zero), keeping positions and springs.
  void ZeroBeadVelocities();

  /// Stops the beads `ids` (indices of beads()), keeping positions and springs. Unlike
  /// ZeroBeadVelocities it keeps the last forces: the next step's opening half kick still
  /// applies their damping, computed with the stopped beads' old velocities.
  void StopBeads(const std::vector<std::uint32_t>& ids);

  /// Threads of the next steps: exactly `threads`, or for 0 OpenMP's default within
  /// threads.h's rule (the usable CPUs, the beads). Results do not depend on it.
  void SetThreads(int threads);
  /// Threads lent to this run now (0: OpenMP's default): as many of them as threads.h's rule
  /// allows for its beads and the usable CPUs, now and as beads are removed. What a run given
  /// a share of the cores calls; SetThreads is for a count wanted exactly (the tests').
  void LendThreads(int threads);
  /// The threads the steps run on now.
  int threads() const;

  /// The tangential histories of all bead contacts in touch (pairs, plate, side wall).
  std::vector<ContactHistoryEntry> ExportHistory() const;

  /// For each bead of beads(), its index in the ParticleState the simulation was made with
  /// (large beds are reordered in memory; RemoveBeads drops the indices of removed beads).
  const std::vector<std::uint32_t>& BeadOrigins() const;

  /// Bytes the simulation's arrays hold (their capacity): beads, neighbour lists, contact
  /// histories, the force pass's blocks and batches. What the benchmark's bytes per bead count.
  std::size_t MemoryBytes() const;

  /// The time spent in each stage of the steps so far.
  const StageTimes& stage_times() const { return m_stage_times; }

  /// Sets the clock (e.g. to continue a run that went on in another simulation).
  void SetClock(double time_s, std::int64_t steps);

  /// All contacts of the current state with their forces (recomputed from the state).
  std::vector<ContactSnapshot> Contacts() const;

  /// Removes every bead for which keep(i) is false; their contacts go with them.
  template <class Keep>
  void RemoveBeads(Keep keep);

  struct Impl;  ///< neighbour lists, contact histories, blocks (src/simulation_state.h)

 private:
  void RemoveBeadsMasked(const std::vector<bool>& keep);
  void ComputeForces();
  void CheckConditions();
  void CompleteKick() const;
  /// The threads of the steps from m_params.threads: exact, or by threads.h's rule when lent
  /// or not given.
  void ApplyThreads();

  WorldParams m_params;
  // Step leaves the beads' closing half kick pending: the next step fuses it with its opening
  // half kick (one pass over the beads instead of two). Whoever reads the beads first completes
  // it, so that they are seen at time_s(); hence mutable.
  mutable ParticleState m_beads;
  mutable bool m_kick_pending = false;
  std::optional<RigidSphere> m_projectile;
  StepObservables m_observables;
  double m_time_s = 0.0;
  std::int64_t m_steps = 0;
  StageTimes m_stage_times;
  std::unique_ptr<Impl> m_impl;
};

template <class Keep>
void Simulation::RemoveBeads(Keep keep) {
  std::vector<bool> mask(m_beads.size());
  for (std::size_t i = 0; i < mask.size(); ++i) mask[i] = keep(i);
  RemoveBeadsMasked(mask);
}

}  // namespace dembuf::dem
