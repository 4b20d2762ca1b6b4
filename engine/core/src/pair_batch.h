// The bead-pair contact law in batches. The pair loop finds the touching pairs of a stretch of
// list entries first (without a branch per entry), then resolves all of them in one loop that
// the compiler vectorizes (gathers, vector sqrt and division, masks for the two friction
// branches), then adds the results to the beads in list order. Each contact goes through
// ResolveContact (parts.h), the one copy of the contact parts' arithmetic that Resolve runs for
// every other contact too (same operations in the same order, no fused multiply-add); the sums are taken in the same order as a
// contact-by-contact loop, so batching changes no bit of a result.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

#include "dembuf/core/contact_law.h"
#include "dembuf/core/parts/parts.h"
#include "dembuf/core/particles.h"

namespace dembuf::dem::detail {

/// The touching pairs of one batch (inputs: bead, partner, list entry) and the law's result
/// for each (force on the bead, torques on both, overlap, new history), as arrays of one
/// component each. The new histories are copied back to the list afterwards: a vector
/// scatter is not available on every CPU, and the gather-only loop vectorizes on all.
struct PairBatch {
  /// A batch covers at most this many list entries.
  static constexpr std::size_t kTarget = 256;
  /// The arrays have that fixed size and lie inside the batch, each at a fixed offset from it:
  /// one register then addresses all of them in the loops. With a pointer each, the adding
  /// loop ran out of registers and reloaded pointers for every contact (5-8% of a step). They
  /// take 30 KB together (held in ForcePassBlocks, one batch a thread).
  template <class T>
  using Column = std::array<T, kTarget>;

  alignas(64) Column<std::uint32_t> bead, partner, entry;
  /// How many beads' entries start at each entry of the batch, from which the pick-out finds
  /// each entry's bead (the list does not keep it: 4 bytes an entry). Zero between batches.
  alignas(64) Column<std::uint32_t> bead_starts{};
  alignas(64) Column<double> overlap;
  alignas(64) Column<double> force[3], torque_bead[3], torque_partner[3], shear[3];
  std::size_t size = 0;
};

/// What the law reads: bead arrays (3 doubles per bead for vectors) and the tangential
/// histories of the list entries.
struct PairBatchInputs {
  const double* position;
  const double* velocity;
  const double* angular_velocity;
  const double* radius;
  const double* mass;   ///< read by parts that read spin (the beads' inertia)
  const double* shear;  ///< per list entry, 3 doubles
  ContactConstants constants;
  /// Read by the instances with species (SpeciesPairs): each bead's species, and the table of
  /// the pairs' constants, row by the bead's species, column by its partner's.
  const Species* species;
  const PairParams* pair_table;
  std::size_t species_count;
};

/// Resolves the contacts of `batch` with the contact parts `active` (parts.h), filling its
/// result arrays (the advanced histories too). Compiled for every instance of the contact
/// parts and several instruction sets (the widest the CPU has is chosen at load time).
void ResolvePairBatch(PartMask active, const PairBatchInputs& in, PairBatch& batch);

/// Contacts of beads with the plate or the side wall, batched like the pairs: the beads that
/// touch (picked out beforehand), where each one's history is (`slot`), and the law's result
/// for each.
struct WallBatch {
  static constexpr std::size_t kTarget = PairBatch::kTarget;
  template <class T>
  using Column = PairBatch::Column<T>;

  alignas(64) Column<std::uint32_t> bead, slot;
  alignas(64) Column<double> overlap, normal_force;
  alignas(64) Column<double> force[3], torque[3], shear[3];
  std::size_t size = 0;
};

struct WallBatchInputs {
  const double* position;
  const double* velocity;
  const double* angular_velocity;
  const double* radius;
  const double* mass;   ///< read by parts that read spin (the beads' inertia)
  const double* shear;  ///< per history slot, 3 doubles: a bead's history with this wall
  ContactConstants constants;
  Container box;
  /// Read by the instances with species: each bead's species and its constants with the walls.
  const Species* species;
  const PairParams* wall_table;
};

/// Resolves the contacts of `batch` with the plate or the side wall (the same arithmetic as
/// the projectile's contacts with them, so the same bits), filling its result arrays.
void ResolveWallBatch(PartMask active, BodyId wall, const WallBatchInputs& in, WallBatch& batch);

}  // namespace dembuf::dem::detail
