// The Simulation: a world's state and its step, velocity Verlet in named stages. Each stage
// lives in its own file: integrator (kick and drift), bead_lists (neighbours), force_pass
// (contacts, with block_schedule for the threads), step_checks (stop with a reason), and
// contact_survey (histories, snapshots, energy).
#include "dembuf/core/simulation.h"

#include "dembuf/core/threads.h"

#include <omp.h>

#include <algorithm>
#include <chrono>
#include <stdexcept>

#include "bead_lists.h"
#include "force_pass.h"
#include "integrator.h"
#include "simulation_state.h"
#include "vector_copies.h"

namespace dembuf::dem {

namespace {

// A table of the species' pairs the size its count asks, and beads all of a species in it (a
// state made without species or layers, bead by bead, is of species 0 in layer 0).
void CheckSpecies(const SpeciesTable& table, ParticleState& beads) {
  if (beads.species.empty()) beads.species.assign(beads.size(), 0);
  if (beads.layer.empty()) beads.layer.assign(beads.size(), 0);
  if (beads.species.size() != beads.size() || beads.layer.size() != beads.size())
    throw std::invalid_argument("Simulation: a species and a layer for each bead");
  const auto count = static_cast<std::size_t>(table.count);
  if (table.count < 1 || table.count > 256 ||
      (table.count > 1 &&
       (table.bead_pair.size() != count * count || table.bead_wall.size() != count ||
        table.projectile_bead.size() != count)))
    throw std::invalid_argument("Simulation: a species table of count^2, count and count pairs");
  for (const Species kind : beads.species)
    if (kind >= count) throw std::invalid_argument("Simulation: a bead of no species in the table");
}

}  // namespace

Simulation::Simulation(const WorldParams& params, ParticleState beads,
                       std::optional<RigidSphere> projectile,
                       const std::vector<ContactHistoryEntry>& history)
    : m_params(params),
      m_beads(std::move(beads)),
      m_projectile(std::move(projectile)),
      m_impl(std::make_unique<Impl>()) {
  // The hot loops' copy is chosen here, where a bad DEMBUF_VECTOR_COPY can be refused with an
  // exception, not at their first call inside a parallel loop.
  detail::ChosenVectorCopy();
  CheckSpecies(m_params.species, m_beads);
  Impl& s = *m_impl;
  if (m_beads.size() > 0) {
    auto [lo, hi] = std::minmax_element(m_beads.radius.begin(), m_beads.radius.end());
    s.lists.min_radius = *lo;
    s.lists.max_radius = *hi;
  }
  s.lists.skin = params.skin_fraction * 2.0 * s.lists.min_radius;
  s.lists.near_gap =
      std::min(s.lists.skin, detail::NeighbourLists::kNearGapDiameters * 2.0 * s.lists.min_radius);
  // The physics parts this world calls for (parts.h): each stage runs the instance of them.
  s.active_parts = ActiveParts(params);
  s.pending_history = history;
  s.parallel = m_beads.size() >= kParallelMinBeads;
  ApplyThreads();
  s.blocks.start = {0, static_cast<std::uint32_t>(m_beads.size())};
  s.origin.resize(m_beads.size());
  for (std::size_t i = 0; i < s.origin.size(); ++i) s.origin[i] = static_cast<std::uint32_t>(i);
}

Simulation::~Simulation() = default;
Simulation::Simulation(Simulation&&) noexcept = default;
Simulation& Simulation::operator=(Simulation&&) noexcept = default;

namespace {

// Seconds since `since`, and `since` moved to now: the stages are timed one after the other.
double Lap(std::chrono::steady_clock::time_point& since) {
  const auto now = std::chrono::steady_clock::now();
  const double seconds = std::chrono::duration<double>(now - since).count();
  since = now;
  return seconds;
}

}  // namespace

void Simulation::Step() {
  Impl& s = *m_impl;
  if (!s.forces_valid) RefreshForces();  // after a change from outside
  auto clock = std::chrono::steady_clock::now();

  // 1. Kick and drift: the last step's pending closing half kick, this step's opening one, and
  // the drift to t + dt, in one pass over the beads; the projectile on its own.
  const bool closing = m_kick_pending;
  m_kick_pending = false;
  const detail::DriftReport drift = detail::KickAndDriftBeads(m_params, closing, m_beads, s);
  s.lists.max_bead_displacement = drift.max_displacement + s.lists.reference_rounding;
  s.conditions.nonfinite_bead = drift.nonfinite_bead;
  s.conditions.escaped_bead = drift.escaped_bead;
  if (m_projectile) {
    RigidSphere& p = *m_projectile;
    detail::HalfKickProjectile(m_params, s.Rotating(), p);
    p.position += m_params.dt_s * p.velocity;
    s.conditions.projectile_bad = !p.position.allFinite() || !p.velocity.allFinite();
  }

  // 2. Check: a non-finite or escaped body stops the run with the reason.
  CheckConditions();
  m_stage_times.integration_s += Lap(clock);

  // 3. Neighbours and 4. forces, then 5. check the overlaps.
  const std::int64_t builds = s.lists.builds, sorts = s.lists.sorts;
  detail::UpdateLists(m_params, m_beads, m_projectile, s);
  m_stage_times.list_builds += s.lists.builds - builds;
  m_stage_times.pair_sorts += s.lists.sorts - sorts;
  m_stage_times.neighbours_s += Lap(clock);
  detail::ComputeForcePass(m_params, m_beads, m_projectile, s, m_observables,
                           /*forces_cleared=*/true);
  s.forces_valid = true;
  CheckConditions();
  m_stage_times.forces_s += Lap(clock);

  // 6. Closing half kick with the new forces: left pending for the beads (the next step does
  // it in its first pass over them, or CompleteKick when anything reads them first).
  m_kick_pending = true;
  if (m_projectile) detail::HalfKickProjectile(m_params, s.Rotating(), *m_projectile);
  m_time_s += m_params.dt_s;
  ++m_steps;
  m_stage_times.integration_s += Lap(clock);
}

void Simulation::ComputeForces() {
  Impl& s = *m_impl;
  detail::UpdateLists(m_params, m_beads, m_projectile, s);
  detail::ComputeForcePass(m_params, m_beads, m_projectile, s, m_observables,
                           /*forces_cleared=*/false);
  s.forces_valid = true;
}

void Simulation::RefreshForces() {
  CompleteKick();  // the pending half kick needs the forces it was computed with
  ComputeForces();
  CheckConditions();
}

void Simulation::CompleteKick() const {
  if (!m_kick_pending) return;
  m_kick_pending = false;
  detail::HalfKickBeads(m_params, m_beads, *m_impl);
}

void Simulation::SetProjectile(const RigidSphere& projectile, double time_s) {
  m_projectile = projectile;
  m_time_s = time_s;
  m_impl->lists.valid = false;
  m_impl->forces_valid = false;
}

double Simulation::BeadKineticEnergy() const {
  CompleteKick();
  double e = 0.0;
  const ParticleState& b = m_beads;
  for (std::size_t i = 0; i < b.size(); ++i) e += b.KineticEnergy(i);
  return e;
}

void Simulation::SetFriction(double sphere_pair, double sphere_wall) {
  if (m_params.species.count > 1)
    throw std::logic_error(
        "SetFriction: a world of several species changes its pairs' with "
        "SetPairConstants");
  CompleteKick();  // with the forces and rotation of the old friction
  m_params.sphere_pair.friction = sphere_pair;
  m_params.sphere_wall.friction = sphere_wall;
  m_impl->active_parts = ActiveParts(m_params);
  m_impl->forces_valid = false;
}

void Simulation::SetPairConstants(const WorldParams& from) {
  if (from.species.count != m_params.species.count)
    throw std::invalid_argument("SetPairConstants: another number of species");
  CompleteKick();  // with the forces and rotation of the old constants
  m_params.sphere_pair = from.sphere_pair;
  m_params.sphere_wall = from.sphere_wall;
  m_params.species = from.species;
  m_impl->active_parts = ActiveParts(m_params);
  m_impl->forces_valid = false;
}

void Simulation::ZeroBeadVelocities() {
  m_kick_pending = false;  // it would only have changed velocities set to zero here
  std::fill(m_beads.velocity.begin(), m_beads.velocity.end(), Vec3::Zero());
  std::fill(m_beads.angular_velocity.begin(), m_beads.angular_velocity.end(), Vec3::Zero());
  m_impl->forces_valid = false;  // the damping forces depended on the old velocities
}

void Simulation::StopBeads(const std::vector<std::uint32_t>& ids) {
  if (ids.empty()) return;
  CompleteKick();  // the others' pending half kick
  for (const std::uint32_t i : ids) {
    m_beads.velocity[i].setZero();
    m_beads.angular_velocity[i].setZero();
  }
  // The forces stay valid: computing them again at the same positions would advance the
  // springs of the beads still moving by a second step. Only the damping of the stopped
  // beads' contacts is stale, for the next half kick.
}

const std::vector<std::uint32_t>& Simulation::BeadOrigins() const {
  return m_impl->origin;
}

void Simulation::SetClock(double time_s, std::int64_t steps) {
  m_time_s = time_s;
  m_steps = steps;
}

namespace {

template <class T>
std::size_t Bytes(const std::vector<T>& v) {
  return v.capacity() * sizeof(T);
}

template <class T, std::size_t N>
std::size_t Bytes(const std::vector<T> (&arrays)[N]) {
  std::size_t sum = 0;
  for (const std::vector<T>& v : arrays) sum += Bytes(v);
  return sum;
}

}  // namespace

std::size_t Simulation::MemoryBytes() const {
  const ParticleState& b = m_beads;
  std::size_t sum = Bytes(b.position) + Bytes(b.velocity) + Bytes(b.angular_velocity) +
                    Bytes(b.force) + Bytes(b.torque) + Bytes(b.radius) + Bytes(b.mass) +
                    Bytes(b.inv_mass) + Bytes(b.species) + Bytes(b.layer);
  const Impl& s = *m_impl;
  const detail::NeighbourLists& l = s.lists;
  sum += l.grid.MemoryBytes() + Bytes(l.pairs.offsets) + Bytes(l.pairs.partners) +
         Bytes(l.pairs.shear) + Bytes(l.pairs.far_offsets) + Bytes(l.pairs.far_partners) +
         Bytes(l.near_projectile.beads) + Bytes(l.near_projectile.shear) + Bytes(l.near_container) +
         Bytes(l.reference_position);
  sum += Bytes(s.walls.plate) + Bytes(s.walls.side);
  const detail::ForcePassBlocks& k = s.blocks;
  sum += Bytes(k.start) + Bytes(k.work) + Bytes(k.done) + Bytes(k.contacts) +
         Bytes(k.near_container_start) + Bytes(k.observables) + Bytes(k.conditions) +
         Bytes(k.pair_batches) + Bytes(k.wall_batches);
  return sum + Bytes(s.pending_history) + Bytes(s.origin);
}

void Simulation::SetThreads(int threads) {
  m_params.threads = threads;
  m_impl->threads_lent = false;
  ApplyThreads();
}

void Simulation::LendThreads(int threads) {
  m_params.threads = threads;
  m_impl->threads_lent = true;
  ApplyThreads();
}

void Simulation::ApplyThreads() {
  Impl& s = *m_impl;
  const int asked = m_params.threads;
  s.threads =
      asked > 0 && !s.threads_lent ? asked : EffectiveThreads(asked, m_beads.size(), UsableCpus());
}

int Simulation::threads() const {
  return m_impl->threads;
}

void Simulation::RemoveBeadsMasked(const std::vector<bool>& keep) {
  CompleteKick();
  Impl& s = *m_impl;
  std::vector<ContactHistoryEntry> history = ExportHistory();
  std::vector<std::uint32_t> new_id(m_beads.size(), kPlate);
  ParticleState kept;
  std::vector<std::uint32_t> origin;
  for (std::size_t i = 0; i < m_beads.size(); ++i) {
    if (!keep[i]) continue;
    new_id[i] = static_cast<std::uint32_t>(kept.size());
    origin.push_back(s.origin[i]);
    kept.AddCopy(m_beads, i);
  }
  s.pending_history.clear();
  for (ContactHistoryEntry h : history) {
    if (!keep[h.bead]) continue;
    const bool wall = h.other == kPlate || h.other == kSideWall;
    if (!wall && !keep[h.other]) continue;
    h.bead = new_id[h.bead];
    if (!wall) h.other = new_id[h.other];
    s.pending_history.push_back(h);
  }
  m_beads = std::move(kept);
  s.walls.plate.clear();  // their histories are pending, named by the new ids
  s.walls.side.clear();
  s.lists.near_container.clear();
  s.origin = std::move(origin);
  s.lists.pairs = detail::PairList{};
  s.lists.near_projectile = detail::CandidateList{};
  s.lists.valid = false;
  s.forces_valid = false;
  ApplyThreads();  // fewer beads may feed fewer threads
}

}  // namespace dembuf::dem
