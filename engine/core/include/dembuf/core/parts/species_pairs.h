// Bead species (docs/model.md "Species"): beads of several materials, each contact reading the
// constants of its kind of pair from a table by the two bodies' species instead of the one
// bead-bead and one bead-wall pair of a world of one material. It adds no arithmetic of its
// own: it changes which constants the other parts read, so the kernels gather them per contact
// only in the instances compiled with it, and a world of one species pays nothing for it.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "dembuf/core/parts/part.h"

namespace dembuf::dem {

/// The species of a bead: an index into SpeciesTable (0 for every bead of a one-species world).
using Species = std::uint8_t;

/// The constants of every kind of pair a world of `count` species has. Species 0's are
/// WorldParams' sphere_pair and sphere_wall; the projectile is of species 0's material.
struct SpeciesTable {
  int count = 1;
  std::vector<PairParams> bead_pair;        ///< count x count, row a, column b (symmetric)
  std::vector<PairParams> bead_wall;        ///< count: a bead of each species on plate or wall
  std::vector<PairParams> projectile_bead;  ///< count: the projectile on a bead of each species

  const PairParams& BeadPair(Species a, Species b) const {
    return bead_pair[static_cast<std::size_t>(a) * count + b];
  }
  /// Whether any pair of the table has friction (MindlinTangential's switch).
  bool AnyFriction() const {
    for (const auto* table : {&bead_pair, &bead_wall, &projectile_bead})
      for (const PairParams& p : *table)
        if (p.friction > 0.0) return true;
    return false;
  }
};

struct SpeciesPairs {
  static constexpr Stage kStage = Stage::kContact;
  static constexpr bool kPicksPairConstants = true;
  /// (A template: WorldParams holds the parts' parameters, so it is defined after them.)
  template <class World>
  static bool On(const World& w) {
    return w.species.count > 1;
  }
};

}  // namespace dembuf::dem
