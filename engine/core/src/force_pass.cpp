#include "force_pass.h"

#include <omp.h>

#include <algorithm>
#include <cmath>

#include "block_schedule.h"
#include "contact_kernels.h"

namespace dembuf::dem::detail {

namespace {

// Clears the springs [first, last) of `history` in one sweep. The force pass clears a whole
// batch's once the law has read them and writes the touching contacts' new ones back, so a
// contact that has opened forgets its spring without a list of those apart.
void ClearSprings(std::vector<Vec3>& history, std::size_t first, std::size_t last) {
  std::fill_n(Components(history) + 3 * first, 3 * (last - first), 0.0);
}

// What the contact parts read of the world for a kind of pair (part.h).
ContactConstants ConstantsOf(const WorldParams& params, const PairParams& pair) {
  return {pair, params.rolling_friction, params.dt_s};
}

// What the pair batches read.
PairBatchInputs PairInputs(const WorldParams& params, ParticleState& b, PairList& pairs) {
  return {Components(b.position),
          Components(b.velocity),
          Components(b.angular_velocity),
          b.radius.data(),
          b.mass.data(),
          Components(pairs.shear),
          ConstantsOf(params, params.sphere_pair),
          b.species.data(),
          params.species.bead_pair.data(),
          static_cast<std::size_t>(params.species.count)};
}

// Pair forces of the beads of block [begin, end), in batches of the list's entries
// (pair_batch.h): the touching pairs are picked out, the law resolves them in one vectorized
// loop, and the results go to the beads in list order. Entries apart lose their history.
template <class E>
void PairForces(const WorldParams& params, ParticleState& b, PairList& pairs, PairBatch& batch,
                std::uint32_t begin, std::uint32_t end, StepObservables& obs,
                StepConditions& cond) {
  if (begin == end) return;  // (a system without beads may have no list at all)
  const std::uint32_t* offsets = pairs.offsets.data();
  const std::uint32_t* partners = pairs.partners.data();
  const PairBatchInputs inputs = PairInputs(params, b, pairs);
  // One flat loop over the entries (not beads, then their entries): no loop exit per bead to
  // mispredict.
  const std::uint32_t stop = offsets[end];
  std::uint32_t first_owner = begin;  // the bead of entry `first`
  for (std::uint32_t first = offsets[begin]; first < stop;) {
    const std::uint32_t last = std::min<std::uint32_t>(stop, first + PairBatch::kTarget);

    // 0. Where the beads after the batch's first start: a count at each one's first entry
    // (beads without entries add theirs to the same place). The pick-out loop below sums them
    // into each entry's bead, with no branch per bead.
    while (offsets[first_owner + 1] <= first) ++first_owner;
    std::uint32_t* starts = batch.bead_starts.data();  // all zero between batches
    for (std::uint32_t next = first_owner + 1; offsets[next] < last; ++next)
      ++starts[offsets[next] - first];

    // 1. Pick out the touching pairs. Every entry is written and the count advances by a
    // comparison's result: no branch to mispredict.
    std::uint32_t* bead = batch.bead.data();
    std::uint32_t* partner = batch.partner.data();
    std::uint32_t* entry = batch.entry.data();
    std::size_t n = 0;
    std::uint32_t owner = first_owner;
    for (std::uint32_t k = first; k < last; ++k) {
      owner += starts[k - first];
      const std::uint32_t i = owner, j = partners[k];
      const double rsum = b.radius[i] + b.radius[j];
      const bool touching = (b.position[i] - b.position[j]).squaredNorm() < rsum * rsum;
      bead[n] = i;
      partner[n] = j;
      entry[n] = k;
      n += touching;
    }
    for (std::uint32_t next = first_owner + 1; offsets[next] < last; ++next)
      starts[offsets[next] - first] = 0;  // zero again for the next batch
    batch.size = n;

    // 2. The contact law, vectorized.
    ResolvePairBatch(E::kParts, inputs, batch);

    // 2b. The law has read the touching entries' springs: the batch's are cleared, and the
    // touching ones get their new springs below.
    if constexpr (E::kHistory) ClearSprings(pairs.shear, first, last);

    // 3. Forces and torques to both beads, in list order; the histories back to the list.
    // A bead's entries are consecutive and name it only as their bead (partners differ from
    // it), so its sums are kept in registers through its run and stored when the bead
    // changes: the same additions in the same order as adding to the bead each time.
    if (n > 0) {
      // Plain pointers to the bead arrays and a local record of the deepest overlap: through the
      // vectors and `cond`, every store below might alias them for the compiler, which would
      // load them again for each contact. (The batch's arrays lie inside it, at fixed offsets.)
      Vec3* force = b.force.data();
      Vec3* torque = b.torque.data();
      Vec3* shear = pairs.shear.data();
      const double* radius = b.radius.data();
      const PairBatch& out = batch;
      StepConditions deepest = cond;
      std::uint32_t current = bead[0];
      Vec3 force_i = force[current];
      Vec3 torque_i = E::kRotate ? torque[current] : Vec3::Zero();
      for (std::size_t c = 0; c < n; ++c) {
        const std::uint32_t i = bead[c], j = partner[c];
        if (i != current) {
          force[current] = force_i;
          force_i = force[i];
          if constexpr (E::kRotate) {
            torque[current] = torque_i;
            torque_i = torque[i];
          }
          current = i;
        }
        const Vec3 f(out.force[0][c], out.force[1][c], out.force[2][c]);
        force_i += f;
        force[j] -= f;
        if constexpr (E::kRotate) {
          torque_i += Vec3(out.torque_bead[0][c], out.torque_bead[1][c], out.torque_bead[2][c]);
          torque[j] +=
              Vec3(out.torque_partner[0][c], out.torque_partner[1][c], out.torque_partner[2][c]);
        }
        if constexpr (E::kHistory)
          shear[entry[c]] = Vec3(out.shear[0][c], out.shear[1][c], out.shear[2][c]);
        deepest.NoteOverlap(out.overlap[c], std::min(radius[i], radius[j]), i, j);
      }
      force[current] = force_i;
      if constexpr (E::kRotate) torque[current] = torque_i;
      cond = deepest;
    }
    obs.bead_contacts += static_cast<int>(n);
    first = last;
  }
}

// Plate and side-wall contacts of the beads lists.near_container[begin, end), in batches like the
// pairs: the beads touching the plate are picked out and resolved in one vectorized loop, then
// those touching the side wall. Each bead gets its plate force before its wall force, as the
// projectile does (ProjectileContainerForces). Beads apart from a wall lose their history with it.
template <class E>
void ContainerForces(const WorldParams& params, ParticleState& b, Simulation::Impl& s,
                     WallBatch& batch, std::uint32_t begin, std::uint32_t end, StepObservables& obs,
                     StepConditions& cond) {
  const Container& box = params.container;
  for (std::uint32_t first = begin; first < end;) {
    const std::uint32_t last = std::min<std::uint32_t>(end, first + WallBatch::kTarget);
    for (const BodyId wall : {kPlate, kSideWall}) {
      const bool plate = wall == kPlate;
      std::vector<Vec3>& history = plate ? s.walls.plate : s.walls.side;
      // Pick out the beads touching this wall, without a branch.
      std::size_t n = 0;
      for (std::uint32_t c = first; c < last; ++c) {
        const std::uint32_t i = s.lists.near_container[c];
        const double x = b.position[i].x(), y = b.position[i].y(), z = b.position[i].z();
        const double r = b.radius[i];
        const bool touching =
            plate ? Container::PlateOverlap(z, r) > 0.0 : box.TouchesSideWall(x, y, z, r);
        batch.bead[n] = i;
        batch.slot[n] = c;
        n += touching;
      }
      batch.size = n;
      const WallBatchInputs inputs{Components(b.position),
                                   Components(b.velocity),
                                   Components(b.angular_velocity),
                                   b.radius.data(),
                                   b.mass.data(),
                                   Components(history),
                                   ConstantsOf(params, params.sphere_wall),
                                   box,
                                   b.species.data(),
                                   params.species.bead_wall.data()};
      ResolveWallBatch(E::kParts, wall, inputs, batch);
      // The law has read the touching beads' springs: the batch's are cleared, and the
      // touching ones get their new springs below.
      if constexpr (E::kHistory) ClearSprings(history, first, last);
      for (std::size_t c = 0; c < n; ++c) {
        const std::uint32_t i = batch.bead[c];
        b.force[i] += Vec3(batch.force[0][c], batch.force[1][c], batch.force[2][c]);
        if constexpr (E::kRotate)
          b.torque[i] += Vec3(batch.torque[0][c], batch.torque[1][c], batch.torque[2][c]);
        if constexpr (E::kHistory)
          history[batch.slot[c]] = Vec3(batch.shear[0][c], batch.shear[1][c], batch.shear[2][c]);
        if (plate)
          obs.plate_force_N += batch.normal_force[c];
        else
          obs.wall_force_z_N += batch.force[2][c];
        cond.NoteOverlap(batch.overlap[c], b.radius[i], i, wall);
      }
    }
    first = last;
  }
}

// Plate and side-wall contacts of the projectile, with the same law and geometry as the
// beads' batches; adds to its force and torque and to the observables and returns how many of
// the two it touches.
template <class E>
int ProjectileContainerForces(const WorldParams& params, RigidSphere& p, Simulation::Impl& s,
                              StepObservables& obs, StepConditions& cond) {
  const Container& box = params.container;
  const Vec3& x = p.position;
  const double r = p.radius;
  auto resolve = [&](const Vec3& normal, double overlap, Vec3& shear) {
    const double arm = LeverArm(r, overlap);
    const ContactGeometry c =
        MakeGeometry(normal, overlap, p.velocity, arm * p.angular_velocity, r);
    const SpinPair spin{p.angular_velocity, p.Inertia()};
    const auto out = Resolve<E>(c, arm, 0.0, ConstantsOf(params, params.sphere_wall), shear, spin);
    p.force += out.force;
    p.torque += out.torque_i;
    return out;
  };
  int touching = 0;
  const double plate_overlap = Container::PlateOverlap(x.z(), r);
  if (plate_overlap > 0.0) {
    obs.plate_force_N += resolve(Vec3::UnitZ(), plate_overlap, s.walls.projectile_plate).normal;
    cond.NoteOverlap(plate_overlap, r, kProjectile, kPlate);
    ++touching;
  } else if constexpr (E::kHistory) {
    s.walls.projectile_plate.setZero();
  }
  double overlap;
  Vec3 n;
  if (SideWallContact(box, x, r, overlap, n)) {
    obs.wall_force_z_N += resolve(n, overlap, s.walls.projectile_side).force.z();
    cond.NoteOverlap(overlap, r, kProjectile, kSideWall);
    ++touching;
  } else if constexpr (E::kHistory) {
    s.walls.projectile_side.setZero();
  }
  return touching;
}

// The projectile against its candidate beads (NeighbourLists::near_projectile); returns the
// contacts.
template <class E>
int ProjectileBeadForces(const WorldParams& params, RigidSphere& p, ParticleState& b,
                         Simulation::Impl& s, StepConditions& cond) {
  int contacts = 0;
  CandidateList& near = s.lists.near_projectile;
  for (std::size_t k = 0; k < near.beads.size(); ++k) {
    const std::uint32_t j = near.beads[k];
    const Vec3 d = p.position - b.position[j];
    const double rj = b.radius[j];
    const double rsum = p.radius + rj;
    const double dist2 = d.squaredNorm();
    Vec3& h = near.shear[k];
    if (dist2 >= rsum * rsum) {
      if constexpr (E::kHistory) h.setZero();
      continue;
    }
    const double dist = std::sqrt(dist2);
    const double overlap = rsum - dist;
    const Vec3 normal = d * (1.0 / dist);
    const double ap = LeverArm(p.radius, overlap), aj = LeverArm(rj, overlap);
    const Vec3 w_arm =
        E::kSlip ? Vec3(ap * p.angular_velocity + aj * b.angular_velocity[j]) : Vec3::Zero();
    const double r_star = EffectiveRadius(p.radius, rj);
    const ContactGeometry c =
        MakeGeometry(normal, overlap, p.velocity - b.velocity[j], w_arm, r_star);
    const SpinPair spin{p.angular_velocity - b.angular_velocity[j],
                        1.0 / (1.0 / p.Inertia() + b.InvInertia(j))};
    const PairParams& pair =
        E::kSpecies ? params.species.projectile_bead[b.species[j]] : params.sphere_pair;
    const auto out = Resolve<E>(c, ap, aj, ConstantsOf(params, pair), h, spin);
    p.force += out.force;
    p.torque += out.torque_i;
    b.force[j] -= out.force;
    if constexpr (E::kRotate) b.torque[j] += out.torque_j;
    ++contacts;
    cond.NoteOverlap(overlap, rj, kProjectile, j);
  }
  return contacts;
}

// The force pass for one set of contact parts: bead pairs (blocks of layers, swept as
// block_schedule.h says), container contacts of the beads near the walls (each thread a run of
// blocks), then the projectile (one body, serial). Observables and conditions are summed per
// block and merged in block order, so the result does not depend on the thread count.
template <class E>
void ForcePass(const WorldParams& params, ParticleState& b, std::optional<RigidSphere>& projectile,
               Simulation::Impl& s, StepObservables& obs, bool forces_cleared) {
  const int blocks = static_cast<int>(s.blocks.start.size()) - 1;
  // Weigh the blocks by the last pass's contacts (not needed by one thread, nor before they
  // are counted; a pass on other weights is not timed for the shares).
  const bool weighed = s.blocks.contacts.size() == static_cast<std::size_t>(blocks);
  if (s.threads > 1 && weighed) WeighBlocks(s);
  s.blocks.observables.assign(blocks, StepObservables{});
  s.blocks.conditions.assign(blocks, StepConditions{});
  const std::uint32_t* start = s.blocks.start.data();
  if (s.blocks.pair_batches.size() < static_cast<std::size_t>(s.threads)) {
    s.blocks.pair_batches.resize(s.threads);
    s.blocks.wall_batches.resize(s.threads);
  }
  s.blocks.shares.Prepare(s.threads);
  int team_size = 1;
  if (s.blocks.done.size() != static_cast<std::size_t>(blocks)) {
    s.blocks.done = std::vector<std::atomic<std::uint64_t>>(blocks);  // all 0
    s.blocks.pass = 0;
  }
  const std::uint64_t pass = ++s.blocks.pass;

#pragma omp parallel num_threads(s.threads) if (s.parallel)
  {
    const int thread = omp_get_thread_num(), team = omp_get_num_threads();
    // Unless the drift has, each thread clears the forces of the beads it integrates (the same
    // part of them).
    if (!forces_cleared) {
      const long n = static_cast<long>(b.size());
      const auto [first_bead, last_bead] = s.blocks.shares.Part(n, thread, team);
      for (long i = first_bead; i < last_bead; ++i) {
        b.force[i].setZero();
        if constexpr (E::kRotate) b.torque[i].setZero();
      }
#pragma omp barrier
    }
    if (thread == 0) team_size = team;
    // This thread's blocks [first, last), in the order of ForcePassBlocks::start.
    const long first = ShareStart(s.blocks.work, s.blocks.shares.Start(thread, team));
    const long last = ShareStart(s.blocks.work, s.blocks.shares.Start(thread + 1, team));
    const double began = omp_get_wtime();
    SweepBlocks(first, last, blocks, s.blocks.done.data(), pass, [&](long k) {
      PairForces<E>(params, b, s.lists.pairs, s.blocks.pair_batches[thread], start[k], start[k + 1],
                    s.blocks.observables[k], s.blocks.conditions[k]);
    });
    const double busy = omp_get_wtime() - began;  // this thread's time in its blocks
    const std::uint64_t done = s.blocks.work[last] - s.blocks.work[first];
#pragma omp barrier
    if (team > 1 && weighed) s.blocks.shares.Record(thread, static_cast<double>(done), busy);
    // Container contacts of the beads near the plate or the wall: each thread takes
    // consecutive blocks holding about its share of those beads.
    const std::vector<std::uint32_t>& near_start = s.blocks.near_container_start;
    const long first_block = ShareStart(near_start, s.blocks.shares.Start(thread, team));
    const long last_block = ShareStart(near_start, s.blocks.shares.Start(thread + 1, team));
    for (long k = first_block; k < last_block; ++k)
      ContainerForces<E>(params, b, s, s.blocks.wall_batches[thread], near_start[k],
                         near_start[k + 1], s.blocks.observables[k], s.blocks.conditions[k]);
  }
  s.blocks.shares.Update(team_size);
  obs = StepObservables{};
  StepConditions& cond = s.conditions;
  s.blocks.contacts.resize(blocks);
  for (int k = 0; k < blocks; ++k) {
    const StepObservables& o = s.blocks.observables[k];
    s.blocks.contacts[k] = static_cast<std::uint32_t>(o.bead_contacts);
    obs.plate_force_N += o.plate_force_N;
    obs.wall_force_z_N += o.wall_force_z_N;
    obs.bead_contacts += o.bead_contacts;
    cond.Merge(s.blocks.conditions[k]);
  }

  if (projectile) {
    RigidSphere& p = *projectile;
    p.force.setZero();
    p.torque.setZero();
    obs.projectile_contacts = ProjectileContainerForces<E>(params, p, s, obs, cond);
    obs.projectile_contacts += ProjectileBeadForces<E>(params, p, b, s, cond);
    obs.projectile_force_N = p.force;
  }
}

}  // namespace

void ComputeForcePass(const WorldParams& params, ParticleState& beads,
                      std::optional<RigidSphere>& projectile, Simulation::Impl& s,
                      StepObservables& obs, bool forces_cleared) {
  WithEffects<Stage::kContact>(s.active_parts, [&]<class E>(E) {
    ForcePass<E>(params, beads, projectile, s, obs, forces_cleared);
  });
}

}  // namespace dembuf::dem::detail
