// What a Simulation keeps besides the beads (Simulation::Impl): neighbour lists, contact
// histories, the blocks of the parallel force pass, and what went wrong in the last pass. The
// stages of a step (integrator.h, bead_lists.h, force_pass.h) work on it.
#pragma once

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "dembuf/core/neighbor_list.h"
#include "dembuf/core/simulation.h"
#include "pair_batch.h"
#include "thread_shares.h"

namespace dembuf::dem {

namespace detail {

// What went wrong in a pass, recorded inside the loops and acted on after them (no throwing
// inside the hot loops). Bodies are BodyIds; kNoBody: none.
inline constexpr BodyId kNoBody = kProjectile - 1;
struct StepConditions {
  double max_overlap_ratio = 0.0;
  BodyId overlap_a = kNoBody, overlap_b = kNoBody;
  long nonfinite_bead = -1;
  long escaped_bead = -1;
  bool projectile_bad = false;
  // Keeps the largest overlap of the pass; the common case costs one multiply and compare.
  void NoteOverlap(double overlap, double radius, BodyId a, BodyId b) {
    if (overlap > max_overlap_ratio * radius) {
      max_overlap_ratio = overlap / radius;
      overlap_a = a;
      overlap_b = b;
    }
  }
  // Combines the record of another block (blocks are merged in a fixed order).
  void Merge(const StepConditions& o) {
    if (o.max_overlap_ratio > max_overlap_ratio) {
      max_overlap_ratio = o.max_overlap_ratio;
      overlap_a = o.overlap_a;
      overlap_b = o.overlap_b;
    }
    nonfinite_bead = std::max(nonfinite_bead, o.nonfinite_bead);
    escaped_bead = std::max(escaped_bead, o.escaped_bead);
    projectile_bad = projectile_bad || o.projectile_bad;
  }
};

// The components of an array of vectors, x y z x y z ...
template <class V>
auto Components(V& vectors) -> decltype(vectors.front().data()) {
  return vectors.empty() ? nullptr : vectors.front().data();
}

}  // namespace detail

namespace detail {

// The neighbour lists and what decides when they are stale (bead_lists.h).
struct NeighbourLists {
  CellGrid grid;
  PairList pairs;                 // bead pairs within the skin, with their histories
  CandidateList near_projectile;  // beads the projectile may touch, with their histories
  // The beads that can touch the plate or the side wall before the next list build (closer to
  // one than a skin, or holding a history with one), in id order. The others' container
  // contacts are skipped: the walls stand still and no bead moves half a skin within a list's
  // life, so skipping them is exact.
  std::vector<std::uint32_t> near_container;
  double skin = 0.0;
  // The pairs closer than this gap form the pair list's near part (PairList), which the force
  // pass checks: kNearGapDiameters of the smallest diameter, or the skin if that is smaller.
  // The smaller the gap, the fewer pairs are checked and the more often the far part is
  // sorted again; 0.05 was the fastest of those measured (0.03 to 0.1) on the impact of a
  // settled bed.
  static constexpr double kNearGapDiameters = 0.05;
  double near_gap = 0.0;
  double max_radius = 0.0;
  double min_radius = 0.0;
  // Bead positions at the last list build or sort of the pairs (x y z x y z ...), in single
  // precision: the displacement test needs far less, and a bead's reference then takes 12
  // bytes, not 24.
  std::vector<float> reference_position;
  // A bound on what that rounding hides of any bead's displacement, added to it.
  double reference_rounding = 0.0;
  Vec3 projectile_reference = Vec3::Zero();
  double max_bead_displacement = 0.0;  // since the reference positions were taken
  // The sum of max_bead_displacement at each sort since the last build: a bead has moved at
  // most this plus max_bead_displacement since the build.
  double displacement_before_sort = 0.0;
  // How far a bead may have moved from the reference positions when the projectile's list
  // was last built (0: with the bead lists).
  double projectile_list_displacement = 0.0;
  bool valid = false;
  std::int64_t builds = 0;  // bead list builds so far
  std::int64_t sorts = 0;   // sorts of the pair list's far part between builds so far
  // The bound on any bead's displacement since the last build.
  double DisplacementSinceBuild() const { return displacement_before_sort + max_bead_displacement; }
};

// The tangential histories of contacts with the plate and the side wall (those of bead pairs
// and of the projectile with beads are in the lists). Only beads near the container can touch
// it, so the histories are kept for them alone: plate[c] and side[c] belong to bead
// NeighbourLists::near_container[c]. A list build hands them on through pending_history.
struct WallHistories {
  std::vector<Vec3> plate;  // one per near-container bead
  std::vector<Vec3> side;   // one per near-container bead
  Vec3 projectile_plate = Vec3::Zero();
  Vec3 projectile_side = Vec3::Zero();
};

// The blocks the parallel force pass is cut into and the threads' shares of the work.
// Beads are kept in cell order (layers of cells across the grid's longest axis,
// CellGrid::SpaceAxis; in a layer, rows of cells), and each layer of cells is a block (k
// numbers both). A pair (i, j > i) found in the 27 cells around i joins a bead of layer k to
// one of layer k or k + 1, so only neighbouring blocks touch the same beads, and the rule "of
// two neighbouring blocks, the even one first" fixes the order of every bead's sum
// (block_schedule.h). The blocks depend on the beads, not on the thread count, and every sum
// is taken in the same order: results are bit-identical for any number of threads.
struct ForcePassBlocks {
  std::vector<std::uint32_t> start{0, 0};  // first bead of each block, and the bead count last
  // The work (list entries + beads) of the blocks before each block, and the total last: each
  // thread takes consecutive blocks of about equal work, which keeps both the balance and the
  // memory locality of a contiguous share.
  std::vector<std::uint64_t> work{0, 1};
  // The force pass (pass) in which each block was done last.
  std::vector<std::atomic<std::uint64_t>> done;
  std::uint64_t pass = 0;
  // The touching pairs of each block in the last force pass, which weigh the blocks' work
  // (empty after a list build, until a pass has counted them).
  std::vector<std::uint32_t> contacts;
  // Where each block's beads start in NeighbourLists::near_container.
  std::vector<std::uint32_t> near_container_start{0, 0};
  std::vector<StepObservables> observables;
  std::vector<StepConditions> conditions;
  std::vector<PairBatch> pair_batches;  // one per thread
  std::vector<WallBatch> wall_batches;  // one per thread
  // Each thread's share of the force and integration passes, following its measured speed.
  ThreadShares shares;
};

}  // namespace detail

struct Simulation::Impl {
  detail::NeighbourLists lists;
  detail::WallHistories walls;
  detail::ForcePassBlocks blocks;
  // Saved histories (a loaded bed, reordered or removed beads), applied at the next list build.
  std::vector<ContactHistoryEntry> pending_history;
  std::vector<std::uint32_t> origin;  // Simulation::BeadOrigins
  // The physics parts this world calls for (parts.h): each kernel is compiled once per set of
  // its stage's parts, and picks its instance from these.
  PartMask active_parts = 0;
  // Beads turn when a part gives them torques.
  bool Rotating() const { return (active_parts & detail::kRotatingParts) != 0; }
  detail::StepConditions conditions;  // what went wrong in the last pass
  bool forces_valid = false;
  int threads = 1;
  bool threads_lent = false;  // LendThreads: the rule applies to the count, also as beads go
  bool parallel = false;      // beds of kParallelMinBeads or more: blocks, threads
};

}  // namespace dembuf::dem
