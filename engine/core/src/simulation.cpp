#include "dembuf/core/simulation.h"

#include <omp.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <sstream>
#include <thread>

#include "contact_kernels.h"
#include "dembuf/core/errors.h"
#include "dembuf/core/neighbor_list.h"
#include "pair_batch.h"
#include "thread_shares.h"

namespace dembuf {

namespace {

// An overlap of this fraction of the smaller radius leaves no sensible contact geometry (the
// centres nearly meet): the run is unstable. Large but smaller overlaps can be genuine in this
// model: a bead pinched between the projectile and the plate carries kilonewtons and Hertz
// then gives overlaps of 30-80% of its radius (glass would break; the model has no breakage).
// Those are reported (StepObservables::max_overlap_ratio), not refused.
constexpr double kMaxOverlapRatio = 0.9;

// Beds of at least this many beads are kept in cell order and processed in parallel blocks;
// smaller systems (two-body tests, a few hundred beads) keep their order and run serially.
constexpr std::size_t kParallelMinBeads = 1024;

// What went wrong in a pass, recorded inside the loops and acted on after them (no throwing
// inside the hot loops).
struct StepConditions {
  double max_overlap_ratio = 0.0;
  long overlap_i = -1, overlap_j = -1;  // -1: plate, -2: side wall, -3: projectile
  long nonfinite_bead = -1;
  long escaped_bead = -1;
  bool projectile_bad = false;
  // Keeps the largest overlap of the pass; the common case costs one multiply and compare.
  void NoteOverlap(double overlap, double radius, long i, long j) {
    if (overlap > max_overlap_ratio * radius) {
      max_overlap_ratio = overlap / radius;
      overlap_i = i;
      overlap_j = j;
    }
  }
  // Combines the record of another block (blocks are merged in a fixed order).
  void Merge(const StepConditions& o) {
    if (o.max_overlap_ratio > max_overlap_ratio) {
      max_overlap_ratio = o.max_overlap_ratio;
      overlap_i = o.overlap_i;
      overlap_j = o.overlap_j;
    }
    nonfinite_bead = std::max(nonfinite_bead, o.nonfinite_bead);
    escaped_bead = std::max(escaped_bead, o.escaped_bead);
    projectile_bad = projectile_bad || o.projectile_bad;
  }
};

const char* BodyName(long id) {
  switch (id) {
    case -1:
      return "the plate";
    case -2:
      return "the side wall";
    case -3:
      return "the projectile";
    default:
      return nullptr;
  }
}

std::string Describe(long id) {
  if (const char* name = BodyName(id)) return name;
  return "bead " + std::to_string(id);
}

}  // namespace

struct Simulation::Impl {
  detail::CellGrid grid;
  detail::PairList pairs;
  detail::CandidateList near_projectile;
  std::vector<Vec3> plate_shear;  // history of each bead's plate contact
  std::vector<Vec3> wall_shear;   // history of each bead's side-wall contact
  Vec3 projectile_plate_shear = Vec3::Zero();
  Vec3 projectile_wall_shear = Vec3::Zero();

  std::vector<Vec3> reference_position;  // bead positions at the last list build
  Vec3 projectile_reference = Vec3::Zero();
  double max_bead_displacement = 0.0;  // since the last list build
  // max_bead_displacement when the projectile's list was last built (0: with the bead lists).
  double projectile_list_displacement = 0.0;
  bool lists_valid = false;
  bool forces_valid = false;

  std::vector<ContactHistoryEntry> pending_history;  // applied at the next list build
  std::vector<std::uint32_t> origin;                 // Simulation::BeadOrigins

  double skin = 0.0;
  double max_radius = 0.0;
  double min_radius = 0.0;
  bool friction = false;
  StepConditions conditions;

  // Parallel force computation. Beads are kept in cell order (layers of cells across the
  // grid's longest axis, CellGrid::SpaceAxis; in a layer, rows of cells), and each layer of
  // cells is a block (k numbers both). A pair (i, j > i) found in the 27 cells around i joins
  // a bead of layer k to one of layer k or k + 1, so only neighbouring blocks touch the same
  // beads, and the rule "of two neighbouring blocks, the even one first" fixes the order of
  // every bead's sum: an even layer's beads take their forces from their own block, then from
  // the one below; an odd layer's from the one below, then from their own. Each thread sweeps
  // its consecutive blocks once in that order (0, 2, 1, 4, 3, ...: each bead's data is still
  // in cache when its forces are complete). An odd block at the edge of a share waits for
  // its even neighbour in the share next to it (block_done), which the thread holding that
  // share does first. The blocks depend on the beads, not on the thread count, and every sum
  // is taken in the same order: results are bit-identical for any number of threads.
  std::vector<std::uint32_t> block_start{0, 0};
  // The work (list entries + beads) of the blocks before each block, and the total last: each
  // thread takes consecutive blocks of about equal work, which keeps both the balance and the
  // memory locality of a contiguous share.
  std::vector<std::uint64_t> block_work{0, 1};
  // The force pass (force_pass) in which each block was done last.
  std::vector<std::atomic<std::uint64_t>> block_done;
  std::uint64_t force_pass = 0;
  // The touching pairs of each block in the last force pass, which weigh the blocks' work
  // (empty after a list build, until a pass has counted them).
  std::vector<std::uint32_t> block_contacts;
  // The beads that can touch the plate or the side wall before the next list build (closer to
  // one than a skin, or holding a history with one), in id order, and where each block's
  // beads start in that list. The others' container contacts are skipped: the walls stand
  // still and no bead moves half a skin within a list's life, so skipping them is exact.
  std::vector<std::uint32_t> near_container;
  std::vector<std::uint32_t> block_near_container{0, 0};
  std::vector<StepObservables> block_observables;
  std::vector<StepConditions> block_conditions;
  std::vector<detail::PairBatch> batches;       // one per thread
  std::vector<detail::WallBatch> wall_batches;  // one per thread
  // Each thread's share of the force and integration passes, following its measured speed.
  detail::ThreadShares shares;
  int threads = 1;
  bool parallel = false;
};

Simulation::Simulation(const WorldParams& params, ParticleState beads,
                       std::optional<RigidSphere> projectile,
                       const std::vector<ContactHistoryEntry>& history)
    : m_params(params),
      m_beads(std::move(beads)),
      m_projectile(std::move(projectile)),
      m_impl(std::make_unique<Impl>()) {
  Impl& s = *m_impl;
  s.plate_shear.assign(m_beads.size(), Vec3::Zero());
  s.wall_shear.assign(m_beads.size(), Vec3::Zero());
  if (m_beads.size() > 0) {
    auto [lo, hi] = std::minmax_element(m_beads.radius.begin(), m_beads.radius.end());
    s.min_radius = *lo;
    s.max_radius = *hi;
  }
  s.skin = params.skin_fraction * 2.0 * s.min_radius;
  // Friction needs the tangential history and rotation; a frictionless scene skips both.
  s.friction = params.sphere_pair.friction > 0.0 || params.sphere_wall.friction > 0.0;
  s.pending_history = history;
  s.parallel = m_beads.size() >= kParallelMinBeads;
  s.threads = params.threads > 0 ? params.threads : omp_get_max_threads();
  s.block_start = {0, static_cast<std::uint32_t>(m_beads.size())};
  s.origin.resize(m_beads.size());
  for (std::size_t i = 0; i < s.origin.size(); ++i) s.origin[i] = static_cast<std::uint32_t>(i);
}

Simulation::~Simulation() = default;
Simulation::Simulation(Simulation&&) noexcept = default;
Simulation& Simulation::operator=(Simulation&&) noexcept = default;

void Simulation::SetProjectile(const RigidSphere& projectile, double time_s) {
  m_projectile = projectile;
  m_time_s = time_s;
  m_impl->lists_valid = false;
  m_impl->forces_valid = false;
}

namespace {

// Plate and side-wall contacts of one sphere (the projectile; the beads' go in batches through
// ContainerForces, with the same arithmetic); adds to force/torque and the observables and
// returns how many of the two it touches.
template <bool kFriction>
int ContainerContacts(const Container& box, const PairParams& p, double dt, const Vec3& x,
                      const Vec3& v, const Vec3& w, double r, Vec3& plate_shear, Vec3& wall_shear,
                      Vec3& force, Vec3& torque, StepObservables& obs, StepConditions& cond,
                      long id) {
  int touching = 0;
  const double plate_overlap = r - x.z();
  if (plate_overlap > 0.0) {
    const double arm = detail::LeverArm(r, plate_overlap);
    const ContactGeometry c =
        detail::MakeGeometry(Vec3::UnitZ(), plate_overlap, v, arm * w, std::sqrt(r));
    const auto out = detail::Resolve<kFriction>(c, arm, 0.0, p, dt, plate_shear);
    force += out.force;
    torque += out.torque_i;
    obs.plate_force_N += out.normal;
    cond.NoteOverlap(plate_overlap, r, id, -1);
    ++touching;
  } else if constexpr (kFriction) {
    plate_shear.setZero();
  }

  double overlap;
  Vec3 n;
  if (detail::SideWallContact(box, x, r, overlap, n)) {
    const double arm = detail::LeverArm(r, overlap);
    const ContactGeometry c = detail::MakeGeometry(n, overlap, v, arm * w, std::sqrt(r));
    const auto out = detail::Resolve<kFriction>(c, arm, 0.0, p, dt, wall_shear);
    force += out.force;
    torque += out.torque_i;
    obs.wall_force_z_N += out.force.z();
    cond.NoteOverlap(overlap, r, id, -2);
    ++touching;
  } else if constexpr (kFriction) {
    wall_shear.setZero();
  }
  return touching;
}

// The components of an array of vectors, x y z x y z ...
template <class V>
auto Components(V& vectors) -> decltype(vectors.front().data()) {
  return vectors.empty() ? nullptr : vectors.front().data();
}

// Pair forces of the beads of block [begin, end), in batches of the list's entries
// (pair_batch.h): the touching pairs are picked out, the law resolves them in one vectorized
// loop, and the results go to the beads in list order. Entries apart lose their history.
template <bool kFriction>
void PairForces(const WorldParams& params, ParticleState& b, detail::PairList& pairs,
                detail::PairBatch& batch, std::uint32_t begin, std::uint32_t end,
                StepObservables& obs, StepConditions& cond) {
  if (begin == end) return;  // (a system without beads may have no list at all)
  const std::uint32_t* owner = pairs.owner.data();
  const std::uint32_t* partners = pairs.partners.data();
  const detail::PairBatchInputs inputs{Components(b.position),
                                       Components(b.velocity),
                                       Components(b.angular_velocity),
                                       b.radius.data(),
                                       pairs.sqrt_r_star.data(),
                                       Components(pairs.shear),
                                       params.sphere_pair,
                                       params.dt_s};
  batch.Reserve(detail::PairBatch::kTarget);
  // One flat loop over the entries (not beads, then their entries): no loop exit per bead to
  // mispredict.
  const std::uint32_t stop = pairs.offsets[end];
  for (std::uint32_t first = pairs.offsets[begin]; first < stop;) {
    const std::uint32_t last = std::min<std::uint32_t>(stop, first + detail::PairBatch::kTarget);

    // 1. Pick out the touching pairs, and the entries apart. Every entry is written and the
    // counts advance by a comparison's result: no branch to mispredict.
    std::uint32_t* bead = batch.bead.data();
    std::uint32_t* partner = batch.partner.data();
    std::uint32_t* entry = batch.entry.data();
    std::uint32_t* apart = batch.apart.data();
    std::size_t n = 0, m = 0;
    for (std::uint32_t k = first; k < last; ++k) {
      const std::uint32_t i = owner[k], j = partners[k];
      const double rsum = b.radius[i] + b.radius[j];
      const bool touching = (b.position[i] - b.position[j]).squaredNorm() < rsum * rsum;
      bead[n] = i;
      partner[n] = j;
      entry[n] = k;
      n += touching;
      if constexpr (kFriction) {
        apart[m] = k;
        m += !touching;
      }
    }
    batch.size = n;

    // 2. The contact law, vectorized.
    detail::ResolvePairBatch(kFriction, inputs, batch);

    // 3. Forces and torques to both beads, in list order; the histories back to the list.
    for (std::size_t c = 0; c < n; ++c) {
      const std::uint32_t i = bead[c], j = partner[c];
      const Vec3 f(batch.force[0][c], batch.force[1][c], batch.force[2][c]);
      b.force[i] += f;
      b.force[j] -= f;
      if constexpr (kFriction) {
        b.torque[i] +=
            Vec3(batch.torque_bead[0][c], batch.torque_bead[1][c], batch.torque_bead[2][c]);
        b.torque[j] += Vec3(batch.torque_partner[0][c], batch.torque_partner[1][c],
                            batch.torque_partner[2][c]);
        pairs.shear[entry[c]] = Vec3(batch.shear[0][c], batch.shear[1][c], batch.shear[2][c]);
      }
      cond.NoteOverlap(batch.overlap[c], std::min(b.radius[i], b.radius[j]), static_cast<long>(i),
                       static_cast<long>(j));
    }
    obs.bead_contacts += static_cast<int>(n);

    // 4. A contact that has opened forgets its history.
    if constexpr (kFriction)
      for (std::size_t a = 0; a < m; ++a) pairs.shear[apart[a]].setZero();
    first = last;
  }
}

// Plate and side-wall contacts of the beads near_container[begin, end), in batches like the
// pairs: the beads touching the plate are picked out and resolved in one vectorized loop, then
// those touching the side wall. Each bead gets its plate force before its wall force, as in
// ContainerContacts. Beads apart from a wall lose their history with it.
template <bool kFriction>
void ContainerForces(const WorldParams& params, ParticleState& b, Simulation::Impl& s,
                     detail::WallBatch& batch, std::uint32_t begin, std::uint32_t end,
                     StepObservables& obs, StepConditions& cond) {
  const Container& box = params.container;
  batch.Reserve(detail::WallBatch::kTarget);
  for (std::uint32_t first = begin; first < end;) {
    const std::uint32_t last = std::min<std::uint32_t>(end, first + detail::WallBatch::kTarget);
    for (const BodyId wall : {kPlate, kSideWall}) {
      const bool plate = wall == kPlate;
      std::vector<Vec3>& history = plate ? s.plate_shear : s.wall_shear;
      // Pick out the beads touching this wall (the tests of ContainerContacts), without a branch.
      std::size_t n = 0, m = 0;
      for (std::uint32_t c = first; c < last; ++c) {
        const std::uint32_t i = s.near_container[c];
        const double x = b.position[i].x(), y = b.position[i].y(), z = b.position[i].z();
        const double r = b.radius[i];
        const double inner = box.radius_m - r;
        const bool touching =
            plate ? r - z > 0.0
                  : (x * x + y * y > inner * inner) & (z >= 0.0) & (z <= box.height_m);
        batch.bead[n] = i;
        n += touching;
        batch.apart[m] = i;
        m += !touching;
      }
      batch.size = n;
      const detail::WallBatchInputs inputs{Components(b.position),
                                           Components(b.velocity),
                                           Components(b.angular_velocity),
                                           b.radius.data(),
                                           Components(history),
                                           params.sphere_wall,
                                           params.dt_s,
                                           box.radius_m};
      detail::ResolveWallBatch(kFriction, wall, inputs, batch);
      for (std::size_t c = 0; c < n; ++c) {
        const std::uint32_t i = batch.bead[c];
        b.force[i] += Vec3(batch.force[0][c], batch.force[1][c], batch.force[2][c]);
        if constexpr (kFriction) {
          b.torque[i] += Vec3(batch.torque[0][c], batch.torque[1][c], batch.torque[2][c]);
          history[i] = Vec3(batch.shear[0][c], batch.shear[1][c], batch.shear[2][c]);
        }
        if (plate)
          obs.plate_force_N += batch.normal_force[c];
        else
          obs.wall_force_z_N += batch.force[2][c];
        cond.NoteOverlap(batch.overlap[c], b.radius[i], static_cast<long>(i), plate ? -1 : -2);
      }
      if constexpr (kFriction)
        for (std::size_t a = 0; a < m; ++a) history[batch.apart[a]].setZero();
    }
    first = last;
  }
}

// The work of the blocks (Impl::block_work): a block's list entries and beads, and its
// touching pairs once a pass has counted them. Resolving a touching pair costs several
// times as much as checking an entry, and touching pairs are not spread evenly: a bed at rest
// is full of them, the beads thrown up by an impact have few.
void WeighBlocks(Simulation::Impl& s) {
  // A touching pair costs about as much as six entries checked (a profile of the impact puts
  // it at 5 to 10); only the split between threads depends on it, never a result.
  constexpr std::uint64_t kContactWork = 6;
  const bool listed = s.pairs.offsets.size() == s.block_start.back() + 1;
  const bool counted = s.block_contacts.size() + 1 == s.block_start.size();
  std::vector<std::uint64_t>& work = s.block_work;
  work.assign(1, 0);
  for (std::size_t k = 0; k + 1 < s.block_start.size(); ++k) {
    const std::uint32_t first = s.block_start[k], last = s.block_start[k + 1];
    const std::uint64_t entries = listed ? s.pairs.offsets[last] - s.pairs.offsets[first] : 0;
    const std::uint64_t contacts = counted ? s.block_contacts[k] : 0;
    // + 1: strictly increasing
    work.push_back(work.back() + entries + kContactWork * contacts + (last - first) + 1);
  }
}

// Waits a moment for another thread (a short spin, then giving the core away: the other
// thread may be waiting for this core when teams are nested or cores are shared).
void Pause(int& spins) {
  if (++spins < 1000) {
#if defined(__x86_64__) || defined(__i386__)
    __builtin_ia32_pause();
#endif
  } else {
    std::this_thread::yield();
  }
}

// Where a thread's run of consecutive items starts when each thread takes about its share of
// their work: `cumulative` holds the work before each item and the total last, `fraction` is
// where the thread's share starts (ThreadShares::Start). 0 gives the first item, 1 one past
// the last.
template <class Work>
long ShareStart(const std::vector<Work>& cumulative, double fraction) {
  const long items = static_cast<long>(cumulative.size()) - 1;
  if (fraction >= 1.0) return items;
  const double target = static_cast<double>(cumulative.back()) * fraction;
  return std::lower_bound(cumulative.begin(), cumulative.end() - 1, target) - cumulative.begin();
}

// The force pass: bead pairs (blocks of layers, Impl::block_start), container contacts of the beads
// near the walls (each thread a run of blocks), then the projectile (one body, serial). Observables
// and conditions are summed per block and merged in block order, so the result does not depend on
// the thread count.
template <bool kFriction>
void ComputeForcesImpl(const WorldParams& params, ParticleState& b,
                       std::optional<RigidSphere>& projectile, Simulation::Impl& s,
                       StepObservables& obs) {
  const double dt = params.dt_s;
  const PairParams pp = params.sphere_pair;
  const PairParams pw = params.sphere_wall;
  const int blocks = static_cast<int>(s.block_start.size()) - 1;
  // Weigh the blocks by the last pass's contacts (not needed by one thread, nor before they
  // are counted; a pass on other weights is not timed for the shares).
  const bool weighed = s.block_contacts.size() == static_cast<std::size_t>(blocks);
  if (s.threads > 1 && weighed) WeighBlocks(s);
  s.block_observables.assign(blocks, StepObservables{});
  s.block_conditions.assign(blocks, StepConditions{});
  const std::uint32_t* start = s.block_start.data();
  if (s.batches.size() < static_cast<std::size_t>(s.threads)) {
    s.batches.resize(s.threads);
    s.wall_batches.resize(s.threads);
  }
  s.shares.Prepare(s.threads);
  int team_size = 1;
  if (s.block_done.size() != static_cast<std::size_t>(blocks)) {
    s.block_done = std::vector<std::atomic<std::uint64_t>>(blocks);  // all 0
    s.force_pass = 0;
  }
  const std::uint64_t pass = ++s.force_pass;
  std::atomic<std::uint64_t>* block_done = s.block_done.data();

#pragma omp parallel num_threads(s.threads) if (s.parallel)
  {
    const int thread = omp_get_thread_num(), team = omp_get_num_threads();
    // Each thread clears the forces of the beads it integrates (the same part of them).
    const long n = static_cast<long>(b.size());
    const auto [first_bead, last_bead] = s.shares.Part(n, thread, team);
    for (long i = first_bead; i < last_bead; ++i) {
      b.force[i].setZero();
      if constexpr (kFriction) b.torque[i].setZero();
    }
#pragma omp barrier
    if (thread == 0) team_size = team;
    // This thread's blocks [first, last), in the order of Impl::block_start.
    const long first = ShareStart(s.block_work, s.shares.Start(thread, team));
    const long last = ShareStart(s.block_work, s.shares.Start(thread + 1, team));
    const double began = omp_get_wtime();
    auto resolve = [&](long k) {
      if (k % 2 == 1)  // odd: after its even neighbours, which may be another thread's
        for (const long even : {k - 1, k + 1})
          if (even >= 0 && even < blocks && (even < first || even >= last))
            for (int spins = 0; block_done[even].load(std::memory_order_acquire) != pass;)
              Pause(spins);
      PairForces<kFriction>(params, b, s.pairs, s.batches[thread], start[k], start[k + 1],
                            s.block_observables[k], s.block_conditions[k]);
      block_done[k].store(pass, std::memory_order_release);
    };
    // An even last block first: the next share's first block may be waiting for it.
    const bool last_first = last > first && (last - 1) % 2 == 0;
    if (last_first) resolve(last - 1);
    for (long even = first + first % 2; even - 1 < last; even += 2) {
      if (even < last && !(last_first && even == last - 1)) resolve(even);
      if (even - 1 >= first) resolve(even - 1);
    }
    const double busy = omp_get_wtime() - began;  // this thread's time in its blocks
    const std::uint64_t done = s.block_work[last] - s.block_work[first];
#pragma omp barrier
    if (team > 1 && weighed) s.shares.Record(thread, static_cast<double>(done), busy);
    // Container contacts of the beads near the plate or the wall: each thread takes
    // consecutive blocks holding about its share of those beads.
    const std::vector<std::uint32_t>& near_start = s.block_near_container;
    const long first_block = ShareStart(near_start, s.shares.Start(thread, team));
    const long last_block = ShareStart(near_start, s.shares.Start(thread + 1, team));
    for (long k = first_block; k < last_block; ++k)
      ContainerForces<kFriction>(params, b, s, s.wall_batches[thread], near_start[k],
                                 near_start[k + 1], s.block_observables[k], s.block_conditions[k]);
  }
  s.shares.Update(team_size);
  obs = StepObservables{};
  StepConditions& cond = s.conditions;
  s.block_contacts.resize(blocks);
  for (int k = 0; k < blocks; ++k) {
    const StepObservables& o = s.block_observables[k];
    s.block_contacts[k] = static_cast<std::uint32_t>(o.bead_contacts);
    obs.plate_force_N += o.plate_force_N;
    obs.wall_force_z_N += o.wall_force_z_N;
    obs.bead_contacts += o.bead_contacts;
    cond.Merge(s.block_conditions[k]);
  }

  if (projectile) {
    RigidSphere& p = *projectile;
    p.force.setZero();
    p.torque.setZero();
    obs.projectile_contacts = ContainerContacts<kFriction>(
        params.container, pw, dt, p.position, p.velocity, p.angular_velocity, p.radius,
        s.projectile_plate_shear, s.projectile_wall_shear, p.force, p.torque, obs, cond, -3);
    const auto& near = s.near_projectile;
    for (std::size_t k = 0; k < near.beads.size(); ++k) {
      const std::uint32_t j = near.beads[k];
      const Vec3 d = p.position - b.position[j];
      const double rj = b.radius[j];
      const double rsum = p.radius + rj;
      const double dist2 = d.squaredNorm();
      Vec3& h = s.near_projectile.shear[k];
      if (dist2 >= rsum * rsum) {
        if constexpr (kFriction) h.setZero();
        continue;
      }
      const double dist = std::sqrt(dist2);
      const double overlap = rsum - dist;
      const Vec3 normal = d * (1.0 / dist);
      const double ap = detail::LeverArm(p.radius, overlap), aj = detail::LeverArm(rj, overlap);
      const Vec3 w_arm =
          kFriction ? Vec3(ap * p.angular_velocity + aj * b.angular_velocity[j]) : Vec3::Zero();
      const ContactGeometry c = detail::MakeGeometry(normal, overlap, p.velocity - b.velocity[j],
                                                     w_arm, std::sqrt(p.radius * rj / rsum));
      const auto out = detail::Resolve<kFriction>(c, ap, aj, pp, dt, h);
      p.force += out.force;
      p.torque += out.torque_i;
      b.force[j] -= out.force;
      if constexpr (kFriction) b.torque[j] += out.torque_j;
      ++obs.projectile_contacts;
      cond.NoteOverlap(overlap, rj, -3, static_cast<long>(j));
    }
    obs.projectile_force_N = p.force;
  }
}

// The per-bead arrays the integrator works on, as components (x y z x y z ...), so that its
// loops vectorize.
struct Kinematics {
  double* position;
  double* velocity;
  double* angular_velocity;
  const double* force;
  const double* torque;
  const double* radius;
  const double* inv_mass;
  const double* inv_inertia;
};

Kinematics BeadKinematics(ParticleState& b) {
  return {Components(b.position), Components(b.velocity), Components(b.angular_velocity),
          Components(b.force),    Components(b.torque),   b.radius.data(),
          b.inv_mass.data(),      b.inv_inertia.data()};
}

// Outside the side wall (below its top) or through the plate: the container leaked.
inline bool Escaped(double x, double y, double z, double r, double wall_r2, double wall_top) {
  return ((z < wall_top) & (x * x + y * y > wall_r2)) | (z < -r);
}

// Half kicks of beads [first, last) with their current forces: v += dt/2 a (and w += dt/2 alpha
// when they rotate), done kHalves times. Two are the last step's closing half kick and this
// step's opening one, in one pass over the beads. Component by component, the operations of
// the Eigen expressions v += half * (f / m + g) and w += half / I * t, in their order.
// A bead with inv_mass 0 is held in place: neither its contacts nor gravity move or turn it.
template <bool kRotate, int kHalves = 1>
void Kick(const Kinematics& k, long first, long last, double half, const Vec3& g) {
  const double gx = g.x(), gy = g.y(), gz = g.z();
#pragma omp simd
  for (long i = first; i < last; ++i) {
    const double inv_m = k.inv_mass[i];
    const bool held = inv_m == 0.0;
    const double dvx = half * (inv_m * k.force[3 * i] + (held ? 0.0 : gx));
    const double dvy = half * (inv_m * k.force[3 * i + 1] + (held ? 0.0 : gy));
    const double dvz = half * (inv_m * k.force[3 * i + 2] + (held ? 0.0 : gz));
    for (int h = 0; h < kHalves; ++h) {
      k.velocity[3 * i] += dvx;
      k.velocity[3 * i + 1] += dvy;
      k.velocity[3 * i + 2] += dvz;
    }
    if constexpr (kRotate) {
      const double s = held ? 0.0 : half * k.inv_inertia[i];
      const double dwx = s * k.torque[3 * i], dwy = s * k.torque[3 * i + 1],
                   dwz = s * k.torque[3 * i + 2];
      for (int h = 0; h < kHalves; ++h) {
        k.angular_velocity[3 * i] += dwx;
        k.angular_velocity[3 * i + 1] += dwy;
        k.angular_velocity[3 * i + 2] += dwz;
      }
    }
  }
}

// The opening half kick (after the last step's closing one when `closing`) and the drift of
// beads [first, last), with the largest squared displacement since the last list build and a
// count of beads that may have gone wrong: non-finite (their components' sum is not finite)
// or outside the container.
template <bool kRotate>
void KickAndDrift(const Kinematics& k, long first, long last, bool closing, double half, double dt,
                  const Vec3& g, const double* reference, double wall_r2, double wall_top,
                  double& max_disp2, long& suspects) {
  if (closing)
    Kick<kRotate, 2>(k, first, last, half, g);
  else
    Kick<kRotate, 1>(k, first, last, half, g);
  double disp2 = 0.0;
  long count = 0;
#pragma omp simd reduction(max : disp2) reduction(+ : count)
  for (long i = first; i < last; ++i) {
    double* x = k.position + 3 * i;
    const double* v = k.velocity + 3 * i;
    x[0] += dt * v[0];
    x[1] += dt * v[1];
    x[2] += dt * v[2];
    const double dx = x[0] - reference[3 * i], dy = x[1] - reference[3 * i + 1],
                 dz = x[2] - reference[3 * i + 2];
    const double d2 = dx * dx + dy * dy + dz * dz;
    disp2 = d2 > disp2 ? d2 : disp2;
    const double sum = ((x[0] + x[1]) + (x[2] + v[0])) + (v[1] + v[2]);
    const bool suspect =
        !std::isfinite(sum) || Escaped(x[0], x[1], x[2], k.radius[i], wall_r2, wall_top);
    count += suspect;
  }
  max_disp2 = std::max(max_disp2, disp2);
  suspects += count;
}

// Restores saved tangential histories into the freshly built lists (a loaded bed, or beads
// that were just reordered). A pair's shear belongs to its lower id; swapping flips its sign.
void ApplyHistory(Simulation::Impl& s) {
  for (ContactHistoryEntry h : s.pending_history) {
    if (h.other == kPlate) {
      s.plate_shear[h.bead] = h.shear;
    } else if (h.other == kSideWall) {
      s.wall_shear[h.bead] = h.shear;
    } else {
      if (h.other < h.bead) {
        std::swap(h.bead, h.other);
        h.shear = -h.shear;
      }
      const auto first = s.pairs.partners.begin() + s.pairs.offsets[h.bead];
      const auto last = s.pairs.partners.begin() + s.pairs.offsets[h.bead + 1];
      const auto it = std::lower_bound(first, last, h.other);
      if (it != last && *it == h.other) s.pairs.shear[it - s.pairs.partners.begin()] = h.shear;
    }
  }
  s.pending_history.clear();
}

template <class T>
void Permute(std::vector<T>& v, const std::vector<std::uint32_t>& order) {
  std::vector<T> out(v.size());
  for (std::size_t k = 0; k < order.size(); ++k) out[k] = v[order[k]];
  v = std::move(out);
}

// Puts the beads in cell order (new bead k is old bead order[k]), carrying every per-bead
// array and contact history along.
void ReorderBeads(ParticleState& b, Simulation::Impl& s, const std::vector<std::uint32_t>& order) {
  std::vector<std::uint32_t> new_id(order.size());
  for (std::size_t k = 0; k < order.size(); ++k) new_id[order[k]] = static_cast<std::uint32_t>(k);
  if (s.pairs.offsets.size() == b.size() + 1) {
    for (std::uint32_t i = 0; i < b.size(); ++i)
      for (std::uint32_t k = s.pairs.offsets[i]; k < s.pairs.offsets[i + 1]; ++k)
        if (s.pairs.shear[k] != Vec3::Zero())
          s.pending_history.push_back({new_id[i], new_id[s.pairs.partners[k]], s.pairs.shear[k]});
  }
  s.pairs = detail::PairList{};
  for (std::uint32_t& j : s.near_projectile.beads) j = new_id[j];
  std::vector<std::size_t> by_id(s.near_projectile.beads.size());
  for (std::size_t k = 0; k < by_id.size(); ++k) by_id[k] = k;
  std::sort(by_id.begin(), by_id.end(), [&](std::size_t a, std::size_t c) {
    return s.near_projectile.beads[a] < s.near_projectile.beads[c];
  });
  detail::CandidateList sorted;
  for (std::size_t k : by_id) {
    sorted.beads.push_back(s.near_projectile.beads[k]);
    sorted.shear.push_back(s.near_projectile.shear[k]);
  }
  s.near_projectile = std::move(sorted);
  Permute(b.position, order);
  Permute(b.velocity, order);
  Permute(b.angular_velocity, order);
  Permute(b.force, order);
  Permute(b.torque, order);
  Permute(b.radius, order);
  Permute(b.mass, order);
  Permute(b.inv_mass, order);
  Permute(b.inv_inertia, order);
  Permute(s.plate_shear, order);
  Permute(s.wall_shear, order);
  Permute(s.origin, order);
}

// Splits the beads (in cell order) into the blocks described at Impl::block_start: one a layer.
void PlanBlocks(Simulation::Impl& s) {
  const int layers = s.grid.Dim(2);
  s.block_start.clear();
  for (int z = 0; z <= layers; ++z) s.block_start.push_back(s.grid.RowStart(0, z));
}

// The beads near the plate or the side wall (Impl::near_container), after the blocks are
// planned and the histories applied.
void ListNearContainer(const ParticleState& b, const Container& box, Simulation::Impl& s) {
  s.near_container.clear();
  for (std::uint32_t i = 0; i < b.size(); ++i) {
    const Vec3& x = b.position[i];
    const double r = b.radius[i];
    const double inner = box.radius_m - r - s.skin;
    const bool near_plate = x.z() - r < s.skin;
    const bool near_wall = inner <= 0.0 || x.x() * x.x() + x.y() * x.y() > inner * inner;
    const bool history = s.plate_shear[i] != Vec3::Zero() || s.wall_shear[i] != Vec3::Zero();
    if (near_plate || near_wall || history) s.near_container.push_back(i);
  }
  s.block_near_container.clear();
  for (const std::uint32_t first : s.block_start)
    s.block_near_container.push_back(static_cast<std::uint32_t>(
        std::lower_bound(s.near_container.begin(), s.near_container.end(), first) -
        s.near_container.begin()));
}

void RebuildLists(const WorldParams& params, ParticleState& b,
                  const std::optional<RigidSphere>& projectile, Simulation::Impl& s) {
  s.block_start = {0, static_cast<std::uint32_t>(b.size())};
  s.block_contacts.clear();
  if (b.size() > 0) {
    // The grid spans the container; beads above the wall top or outside it are clamped into
    // the border cells. Its height follows the beads, so a shallow bed has few cells.
    double z_top = 0.0;
    for (const Vec3& x : b.position) z_top = std::max(z_top, x.z());
    z_top = std::min(z_top, params.container.height_m + 0.5);
    const double cell = 2.0 * s.max_radius + s.skin;
    const double margin = 2.0 * s.max_radius;
    const Vec3 lo(-params.container.radius_m - margin, -params.container.radius_m - margin,
                  -margin);
    const Vec3 hi(params.container.radius_m + margin, params.container.radius_m + margin,
                  z_top + margin);
    s.grid.Build(b.position, cell, lo, hi);
    s.parallel = b.size() >= kParallelMinBeads;
    if (s.parallel) {
      if (!s.grid.InCellOrder()) {
        ReorderBeads(b, s, std::vector<std::uint32_t>(s.grid.CellOrder()));
        s.grid.Build(b.position, cell, lo, hi);
      }
      PlanBlocks(s);
    }
    detail::RebuildPairList(b, s.grid, s.skin, s.pairs, s.parallel ? s.threads : 1);
    ApplyHistory(s);
    s.reference_position = b.position;
    if (projectile)
      detail::RebuildCandidateList(b, s.grid, projectile->position, projectile->radius,
                                   s.max_radius, s.skin, s.near_projectile);
  }
  WeighBlocks(s);
  ListNearContainer(b, params.container, s);
  if (projectile) s.projectile_reference = projectile->position;
  s.max_bead_displacement = 0.0;
  s.projectile_list_displacement = 0.0;
  s.lists_valid = true;
}

// A fast projectile outruns its list long before the beads outrun theirs: rebuild only its
// candidates, from the bead grid of the last full build (beads have moved less than half a
// skin since, which the search box allows for).
void RebuildProjectileList(const ParticleState& b, const RigidSphere& projectile,
                           Simulation::Impl& s) {
  if (b.size() > 0)
    detail::RebuildCandidateList(b, s.grid, projectile.position, projectile.radius, s.max_radius,
                                 s.skin, s.near_projectile, s.max_bead_displacement);
  s.projectile_reference = projectile.position;
  s.projectile_list_displacement = s.max_bead_displacement;
}

// The bead lists stay valid while no pair can have closed the skin: two beads moving towards
// each other by at most d each.
bool BeadListsValid(const Simulation::Impl& s) {
  return s.lists_valid && 2.0 * s.max_bead_displacement < s.skin;
}

// The projectile's list stays valid while its own displacement plus a bead's since the list
// was built stays below the skin. A bead's displacement since then is at most its present
// displacement from the bead reference plus what it had when the list was built.
bool ProjectileListValid(const RigidSphere& projectile, const Simulation::Impl& s) {
  const double moved = (projectile.position - s.projectile_reference).norm();
  return moved + s.max_bead_displacement + s.projectile_list_displacement < s.skin;
}

[[noreturn]] void Fail(const std::string& what, std::int64_t step, double t) {
  std::ostringstream msg;
  msg << "simulation unstable at step " << step << " (t = " << t << " s): " << what;
  throw SimulationError(msg.str(), step, t);
}

}  // namespace

void Simulation::ComputeForces() {
  Impl& s = *m_impl;
  if (!BeadListsValid(s)) {
    RebuildLists(m_params, m_beads, m_projectile, s);
  } else if (m_projectile && !ProjectileListValid(*m_projectile, s)) {
    RebuildProjectileList(m_beads, *m_projectile, s);
  }
  // The only dispatch on configuration: each kernel is compiled for its set of effects.
  if (s.friction) {
    ComputeForcesImpl<true>(m_params, m_beads, m_projectile, s, m_observables);
  } else {
    ComputeForcesImpl<false>(m_params, m_beads, m_projectile, s, m_observables);
  }
  s.forces_valid = true;
}

void Simulation::RefreshForces() {
  CompleteKick();  // the pending half kick needs the forces it was computed with
  ComputeForces();
  CheckConditions();
}

void Simulation::Step() {
  Impl& s = *m_impl;
  const double dt = m_params.dt_s;
  const double half = 0.5 * dt;
  const Vec3 g(0.0, 0.0, -m_params.gravity_m_s2);
  if (!s.forces_valid) RefreshForces();

  // Velocity Verlet, first half: kick to t + dt/2 (after the last step's closing half kick,
  // left pending by it), drift to t + dt.
  const bool closing = m_kick_pending;
  m_kick_pending = false;
  const long n = static_cast<long>(m_beads.size());
  const double wall_r2 = m_params.container.radius_m * m_params.container.radius_m;
  const double wall_top = m_params.container.height_m;
  const bool rotate = s.friction;
  ParticleState& b = m_beads;
  const Kinematics k = BeadKinematics(b);
  const double* reference = Components(s.reference_position);
  double max_disp2 = 0.0;
  long suspects = 0;  // beads that may be non-finite or outside the container
#pragma omp parallel num_threads(s.threads) if (s.parallel)
  {
    double thread_disp2 = 0.0;
    long thread_suspects = 0;
    const int team = omp_get_num_threads(), thread = omp_get_thread_num();
    const auto [first, last] = s.shares.Part(n, thread, team);
    if (rotate)
      KickAndDrift<true>(k, first, last, closing, half, dt, g, reference, wall_r2, wall_top,
                         thread_disp2, thread_suspects);
    else
      KickAndDrift<false>(k, first, last, closing, half, dt, g, reference, wall_r2, wall_top,
                          thread_disp2, thread_suspects);
#pragma omp critical
    {
      max_disp2 = std::max(max_disp2, thread_disp2);
      suspects += thread_suspects;
    }
  }
  long nonfinite = -1, escaped = -1;
  if (suspects > 0) {  // rare: find the beads for the message
    for (long i = 0; i < n; ++i) {
      const Vec3& x = b.position[i];
      if (!x.allFinite() || !b.velocity[i].allFinite()) nonfinite = i;
      if (Escaped(x.x(), x.y(), x.z(), b.radius[i], wall_r2, wall_top)) escaped = i;
    }
  }
  s.conditions.nonfinite_bead = nonfinite;
  s.conditions.escaped_bead = escaped;
  s.max_bead_displacement = std::sqrt(max_disp2);
  if (m_projectile) {
    RigidSphere& p = *m_projectile;
    p.velocity += half * (p.force / p.mass + g);
    p.position += dt * p.velocity;
    if (rotate) p.angular_velocity += half * p.torque / p.Inertia();
    s.conditions.projectile_bad = !p.position.allFinite() || !p.velocity.allFinite();
  }
  CheckConditions();

  ComputeForces();
  CheckConditions();

  // Second half kick with the new forces: left pending for the beads (the next step does it
  // in its first pass over them, or CompleteKick when someone looks at them first).
  m_kick_pending = true;
  if (m_projectile) {
    RigidSphere& p = *m_projectile;
    p.velocity += half * (p.force / p.mass + g);
    if (rotate) p.angular_velocity += half * p.torque / p.Inertia();
  }
  m_time_s += dt;
  ++m_steps;
}

void Simulation::CompleteKick() const {
  if (!m_kick_pending) return;
  m_kick_pending = false;
  const Impl& s = *m_impl;
  const double half = 0.5 * m_params.dt_s;
  const Vec3 g(0.0, 0.0, -m_params.gravity_m_s2);
  const long n = static_cast<long>(m_beads.size());
  const Kinematics k = BeadKinematics(m_beads);
#pragma omp parallel num_threads(s.threads) if (s.parallel)
  {
    const int team = omp_get_num_threads(), thread = omp_get_thread_num();
    const auto [first, last] = s.shares.Part(n, thread, team);
    if (s.friction)
      Kick<true>(k, first, last, half, g);
    else
      Kick<false>(k, first, last, half, g);
  }
}

void Simulation::CheckConditions() {
  StepConditions& c = m_impl->conditions;
  if (c.nonfinite_bead >= 0)
    Fail("bead " + std::to_string(c.nonfinite_bead) + " has a non-finite position or velocity",
         m_steps, m_time_s);
  if (c.projectile_bad)
    Fail("the projectile has a non-finite position or velocity", m_steps, m_time_s);
  if (c.escaped_bead >= 0) {
    const Vec3& x = m_beads.position[c.escaped_bead];
    std::ostringstream what;
    what << "bead " << c.escaped_bead << " left the container (x, y, z = " << x.x() << ", " << x.y()
         << ", " << x.z() << " m; wall radius " << m_params.container.radius_m << " m, height "
         << m_params.container.height_m << " m)";
    const double rho = std::hypot(x.x(), x.y());
    if (x.z() < 0.0)
      what << ": through the plate; the time step is too large (lower time.alpha)";
    else if (rho > m_params.container.radius_m + 2.0 * m_beads.radius[c.escaped_bead])
      what << ": thrown over the rim and fallen outside (raise cylinder.height_m)";
    else
      what << ": through the side wall; the time step is too large (lower time.alpha)";
    Fail(what.str(), m_steps, m_time_s);
  }
  m_observables.max_overlap_ratio = std::max(m_observables.max_overlap_ratio, c.max_overlap_ratio);
  if (c.max_overlap_ratio > kMaxOverlapRatio) {
    std::ostringstream what;
    what << "overlap of " << Describe(c.overlap_i) << " and " << Describe(c.overlap_j)
         << " reached " << c.max_overlap_ratio * 100.0 << "% of the smaller radius (limit "
         << kMaxOverlapRatio * 100.0
         << "%): the time step is too large for the speeds in this scene (lower time.alpha)";
    Fail(what.str(), m_steps, m_time_s);
  }
  c = StepConditions{};
}

double Simulation::BeadKineticEnergy() const {
  CompleteKick();
  double e = 0.0;
  const ParticleState& b = m_beads;
  for (std::size_t i = 0; i < b.size(); ++i) e += b.KineticEnergy(i);
  return e;
}

void Simulation::SetFriction(double sphere_pair, double sphere_wall) {
  CompleteKick();  // with the forces and rotation of the old friction
  m_params.sphere_pair.friction = sphere_pair;
  m_params.sphere_wall.friction = sphere_wall;
  m_impl->friction = sphere_pair > 0.0 || sphere_wall > 0.0;
  m_impl->forces_valid = false;
}

void Simulation::ZeroBeadVelocities() {
  m_kick_pending = false;  // it would only have changed velocities set to zero here
  std::fill(m_beads.velocity.begin(), m_beads.velocity.end(), Vec3::Zero());
  std::fill(m_beads.angular_velocity.begin(), m_beads.angular_velocity.end(), Vec3::Zero());
  m_impl->forces_valid = false;  // the damping forces depended on the old velocities
}

const std::vector<std::uint32_t>& Simulation::BeadOrigins() const {
  return m_impl->origin;
}

void Simulation::SetClock(double time_s, std::int64_t steps) {
  m_time_s = time_s;
  m_steps = steps;
}

void Simulation::SetThreads(int threads) {
  m_params.threads = threads;
  m_impl->threads = threads > 0 ? threads : omp_get_max_threads();
}

std::vector<ContactHistoryEntry> Simulation::ExportHistory() const {
  CompleteKick();
  const Impl& s = *m_impl;
  std::vector<ContactHistoryEntry> out;
  out.insert(out.end(), s.pending_history.begin(), s.pending_history.end());
  for (std::uint32_t i = 0; i < m_beads.size(); ++i) {
    if (s.plate_shear[i] != Vec3::Zero()) out.push_back({i, kPlate, s.plate_shear[i]});
    if (s.wall_shear[i] != Vec3::Zero()) out.push_back({i, kSideWall, s.wall_shear[i]});
  }
  if (s.pairs.offsets.size() == m_beads.size() + 1) {
    for (std::uint32_t i = 0; i < m_beads.size(); ++i)
      for (std::uint32_t k = s.pairs.offsets[i]; k < s.pairs.offsets[i + 1]; ++k)
        if (s.pairs.shear[k] != Vec3::Zero())
          out.push_back({i, s.pairs.partners[k], s.pairs.shear[k]});
  }
  return out;
}

void Simulation::RemoveBeadsMasked(const std::vector<bool>& keep) {
  CompleteKick();
  Impl& s = *m_impl;
  std::vector<ContactHistoryEntry> history = ExportHistory();
  std::vector<std::uint32_t> new_id(m_beads.size(), kPlate);
  ParticleState kept;
  std::vector<Vec3> plate_shear, wall_shear;
  std::vector<std::uint32_t> origin;
  for (std::size_t i = 0; i < m_beads.size(); ++i) {
    if (!keep[i]) continue;
    new_id[i] = static_cast<std::uint32_t>(kept.size());
    origin.push_back(s.origin[i]);
    kept.AddCopy(m_beads, i);
    plate_shear.push_back(Vec3::Zero());
    wall_shear.push_back(Vec3::Zero());
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
  s.plate_shear = std::move(plate_shear);
  s.wall_shear = std::move(wall_shear);
  s.origin = std::move(origin);
  s.pairs = detail::PairList{};
  s.near_projectile = detail::CandidateList{};
  s.lists_valid = false;
  s.forces_valid = false;
}

namespace {

// Every contact of the current state, with its geometry, for the few places that look at
// contacts outside the force kernel (snapshots, energy). visit(a, b, n, overlap, v_rel,
// radius_a, sqrt_r_star, params, shear, x_a) with a and b as in ContactSnapshot.
template <class Visit>
void VisitContacts(const WorldParams& params, const ParticleState& b,
                   const std::optional<RigidSphere>& projectile, const Simulation::Impl& s,
                   Visit&& visit) {
  if (s.pairs.offsets.size() == b.size() + 1) {
    for (std::uint32_t i = 0; i < b.size(); ++i)
      for (std::uint32_t k = s.pairs.offsets[i]; k < s.pairs.offsets[i + 1]; ++k) {
        const std::uint32_t j = s.pairs.partners[k];
        const Vec3 d = b.position[i] - b.position[j];
        const double rsum = b.radius[i] + b.radius[j], dist = d.norm();
        if (dist >= rsum) continue;
        visit(i, j, Vec3(d / dist), rsum - dist, Vec3(b.velocity[i] - b.velocity[j]), b.radius[i],
              std::sqrt(b.radius[i] * b.radius[j] / rsum), params.sphere_pair, s.pairs.shear[k],
              b.position[i]);
      }
  }
  auto walls = [&](BodyId id, const Vec3& x, const Vec3& v, double r, const Vec3& plate,
                   const Vec3& wall) {
    if (r - x.z() > 0.0)
      visit(id, kPlate, Vec3(Vec3::UnitZ()), r - x.z(), v, r, std::sqrt(r), params.sphere_wall,
            plate, x);
    double overlap;
    Vec3 n;
    if (detail::SideWallContact(params.container, x, r, overlap, n))
      visit(id, kSideWall, n, overlap, v, r, std::sqrt(r), params.sphere_wall, wall, x);
  };
  for (std::uint32_t i = 0; i < b.size(); ++i)
    walls(i, b.position[i], b.velocity[i], b.radius[i], s.plate_shear[i], s.wall_shear[i]);
  if (projectile) {
    const RigidSphere& p = *projectile;
    walls(kProjectile, p.position, p.velocity, p.radius, s.projectile_plate_shear,
          s.projectile_wall_shear);
    for (std::size_t k = 0; k < s.near_projectile.beads.size(); ++k) {
      const std::uint32_t j = s.near_projectile.beads[k];
      const Vec3 d = p.position - b.position[j];
      const double rsum = p.radius + b.radius[j], dist = d.norm();
      if (dist >= rsum) continue;
      visit(kProjectile, j, Vec3(d / dist), rsum - dist, Vec3(p.velocity - b.velocity[j]), p.radius,
            std::sqrt(p.radius * b.radius[j] / rsum), params.sphere_pair,
            s.near_projectile.shear[k], p.position);
    }
  }
}

}  // namespace

std::vector<ContactSnapshot> Simulation::Contacts() const {
  CompleteKick();
  std::vector<ContactSnapshot> out;
  // Normal force from the law with the current velocities, tangential from the stored spring
  // (already capped by Coulomb in the last step).
  VisitContacts(
      m_params, m_beads, m_projectile, *m_impl,
      [&](BodyId a, BodyId other, const Vec3& n, double overlap, const Vec3& v_rel, double ra,
          double sqrt_r, const PairParams& p, const Vec3& shear, const Vec3& x_a) {
        const double fn = HertzNormalForce(overlap, -v_rel.dot(n), sqrt_r, p);
        const Vec3 ft = StoredSpringForce(overlap, sqrt_r, p, shear);
        out.push_back({a, other, x_a - detail::LeverArm(ra, overlap) * n, fn * n + ft, fn});
      });
  return out;
}

EnergyBreakdown Simulation::Energy() const {
  CompleteKick();
  EnergyBreakdown e;
  const double g = m_params.gravity_m_s2;
  const ParticleState& b = m_beads;
  for (std::size_t i = 0; i < b.size(); ++i) {
    e.kinetic_J += b.KineticEnergy(i);
    e.potential_J += b.mass[i] * g * b.position[i].z();
  }
  if (m_projectile) {
    const RigidSphere& p = *m_projectile;
    e.kinetic_J += 0.5 * p.mass * p.velocity.squaredNorm() +
                   0.5 * p.Inertia() * p.angular_velocity.squaredNorm();
    e.potential_J += p.mass * g * p.position.z();
  }
  VisitContacts(m_params, m_beads, m_projectile, *m_impl,
                [&](std::int64_t, std::int64_t, const Vec3&, double overlap, const Vec3&, double,
                    double sqrt_r, const PairParams& p, const Vec3& shear, const Vec3&) {
                  e.elastic_J += ContactElasticEnergy(overlap, sqrt_r, p, shear);
                });
  return e;
}

}  // namespace dembuf
