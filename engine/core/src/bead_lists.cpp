#include "bead_lists.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "block_schedule.h"

namespace dembuf::dem::detail {

namespace {

// Hands the wall histories, kept per near-container bead, to pending_history, so that they
// follow the beads through a reorder and find their slots in the next near-container list.
void PendWallHistories(Simulation::Impl& s) {
  for (std::size_t c = 0; c < s.walls.plate.size(); ++c) {
    const std::uint32_t i = s.lists.near_container[c];
    if (s.walls.plate[c] != Vec3::Zero())
      s.pending_history.push_back({i, kPlate, s.walls.plate[c]});
    if (s.walls.side[c] != Vec3::Zero())
      s.pending_history.push_back({i, kSideWall, s.walls.side[c]});
  }
  s.walls.plate.clear();
  s.walls.side.clear();
}

// Restores the saved pair histories into the freshly built pair list (a loaded bed, or beads
// that were just reordered) and returns the wall histories, which wait for the near-container
// list. A pair's shear belongs to its lower id; swapping flips its sign.
std::vector<ContactHistoryEntry> ApplyPairHistory(Simulation::Impl& s) {
  std::vector<ContactHistoryEntry> walls;
  for (ContactHistoryEntry h : s.pending_history) {
    if (h.other == kPlate || h.other == kSideWall) {
      walls.push_back(h);
      continue;
    }
    if (h.other < h.bead) {
      std::swap(h.bead, h.other);
      h.shear = -h.shear;
    }
    const auto first = s.lists.pairs.partners.begin() + s.lists.pairs.offsets[h.bead];
    const auto last = s.lists.pairs.partners.begin() + s.lists.pairs.offsets[h.bead + 1];
    const auto it = std::lower_bound(first, last, h.other);
    if (it != last && *it == h.other)
      s.lists.pairs.shear[it - s.lists.pairs.partners.begin()] = h.shear;
  }
  // Let its memory go too (a loaded bed's histories are some 60 bytes a bead).
  std::vector<ContactHistoryEntry>().swap(s.pending_history);
  return walls;
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
  // Histories still waiting to be applied (a saved bed's, or those RemoveBeads kept) name the
  // beads by their old ids too.
  for (ContactHistoryEntry& h : s.pending_history) {
    h.bead = new_id[h.bead];
    if (IsBead(h.other)) h.other = new_id[h.other];
  }
  if (s.lists.pairs.offsets.size() == b.size() + 1) {
    for (std::uint32_t i = 0; i < b.size(); ++i)
      for (std::uint32_t k = s.lists.pairs.offsets[i]; k < s.lists.pairs.offsets[i + 1]; ++k)
        if (s.lists.pairs.shear[k] != Vec3::Zero())
          s.pending_history.push_back(
              {new_id[i], new_id[s.lists.pairs.partners[k]], s.lists.pairs.shear[k]});
  }
  s.lists.pairs = PairList{};
  for (std::uint32_t& j : s.lists.near_projectile.beads) j = new_id[j];
  std::vector<std::size_t> by_id(s.lists.near_projectile.beads.size());
  for (std::size_t k = 0; k < by_id.size(); ++k) by_id[k] = k;
  std::sort(by_id.begin(), by_id.end(), [&](std::size_t a, std::size_t c) {
    return s.lists.near_projectile.beads[a] < s.lists.near_projectile.beads[c];
  });
  CandidateList sorted;
  for (std::size_t k : by_id) {
    sorted.beads.push_back(s.lists.near_projectile.beads[k]);
    sorted.shear.push_back(s.lists.near_projectile.shear[k]);
  }
  s.lists.near_projectile = std::move(sorted);
  Permute(b.position, order);
  Permute(b.velocity, order);
  Permute(b.angular_velocity, order);
  Permute(b.force, order);
  Permute(b.torque, order);
  Permute(b.radius, order);
  Permute(b.mass, order);
  Permute(b.inv_mass, order);
  Permute(b.species, order);
  Permute(b.layer, order);
  Permute(s.origin, order);
}

// Keeps the positions of the list build in single precision. Rounding moves a component by at
// most 2^-24 of its size, so a displacement from the kept position is within sqrt(3) 2^-24
// times the largest coordinate of the true one; the bound allows twice that.
void KeepReferencePositions(const ParticleState& b, NeighbourLists& lists, int threads) {
  const long n = static_cast<long>(b.size());
  lists.reference_position.resize(3 * b.size());
  float* kept = lists.reference_position.data();
  const Vec3* x = b.position.data();
  double largest = 0.0;  // (a maximum: the same whatever the threads' order)
#pragma omp parallel for schedule(static) reduction(max        \
                                                    : largest) \
    num_threads(threads) if (threads > 1)
  for (long i = 0; i < n; ++i)
    for (int d = 0; d < 3; ++d) {
      kept[3 * i + d] = static_cast<float>(x[i][d]);
      largest = std::max(largest, std::abs(x[i][d]));
    }
  lists.reference_rounding = std::sqrt(3.0) * std::numeric_limits<float>::epsilon() * largest;
}

// Splits the beads (in cell order) into the blocks described at ForcePassBlocks: one a layer.
void PlanBlocks(Simulation::Impl& s) {
  const int layers = s.lists.grid.Dim(2);
  s.blocks.start.clear();
  for (int z = 0; z <= layers; ++z) s.blocks.start.push_back(s.lists.grid.RowStart(0, z));
}

// The beads near the plate or the side wall (NeighbourLists::near_container), after the blocks are
// planned, and their wall histories (`saved`, from ApplyPairHistory) in their slots.
void ListNearContainer(const ParticleState& b, const Container& box,
                       std::vector<ContactHistoryEntry> saved, Simulation::Impl& s) {
  std::sort(
      saved.begin(), saved.end(),
      [](const ContactHistoryEntry& a, const ContactHistoryEntry& c) { return a.bead < c.bead; });
  s.lists.near_container.clear();
  auto next_saved = saved.begin();
  for (std::uint32_t i = 0; i < b.size(); ++i) {
    const Vec3& x = b.position[i];
    const double r = b.radius[i];
    const double inner = box.radius_m - r - s.lists.skin;
    const bool near_plate = x.z() - r < s.lists.skin;
    const bool near_wall = inner <= 0.0 || x.x() * x.x() + x.y() * x.y() > inner * inner;
    while (next_saved != saved.end() && next_saved->bead < i) ++next_saved;
    const bool history = next_saved != saved.end() && next_saved->bead == i;
    if (near_plate || near_wall || history) s.lists.near_container.push_back(i);
  }
  s.walls.plate.assign(s.lists.near_container.size(), Vec3::Zero());
  s.walls.side.assign(s.lists.near_container.size(), Vec3::Zero());
  for (const ContactHistoryEntry& h : saved) {
    const auto slot =
        std::lower_bound(s.lists.near_container.begin(), s.lists.near_container.end(), h.bead) -
        s.lists.near_container.begin();
    (h.other == kPlate ? s.walls.plate : s.walls.side)[slot] = h.shear;
  }
  s.blocks.near_container_start.clear();
  for (const std::uint32_t first : s.blocks.start)
    s.blocks.near_container_start.push_back(static_cast<std::uint32_t>(
        std::lower_bound(s.lists.near_container.begin(), s.lists.near_container.end(), first) -
        s.lists.near_container.begin()));
}

void RebuildLists(const WorldParams& params, ParticleState& b,
                  const std::optional<RigidSphere>& projectile, Simulation::Impl& s) {
  s.blocks.start = {0, static_cast<std::uint32_t>(b.size())};
  s.blocks.contacts.clear();
  PendWallHistories(s);
  std::vector<ContactHistoryEntry> wall_history;
  if (b.size() > 0) {
    // The grid spans the container; beads above the wall top or outside it are clamped into
    // the border cells. Its height follows the beads, so a shallow bed has few cells.
    double z_top = 0.0;
    for (const Vec3& x : b.position) z_top = std::max(z_top, x.z());
    z_top = std::min(z_top, params.container.height_m + 0.5);
    const double cell = 2.0 * s.lists.max_radius + s.lists.skin;
    const double margin = 2.0 * s.lists.max_radius;
    const Vec3 lo(-params.container.radius_m - margin, -params.container.radius_m - margin,
                  -margin);
    const Vec3 hi(params.container.radius_m + margin, params.container.radius_m + margin,
                  z_top + margin);
    s.lists.grid.Build(b.position, cell, lo, hi);
    s.parallel = b.size() >= kParallelMinBeads;
    if (s.parallel) {
      if (!s.lists.grid.InCellOrder()) {
        ReorderBeads(b, s, std::vector<std::uint32_t>(s.lists.grid.CellOrder()));
        s.lists.grid.Build(b.position, cell, lo, hi);
      }
      PlanBlocks(s);
    }
    RebuildPairList(b, s.lists.grid, s.lists.skin, s.lists.near_gap, s.lists.pairs,
                    s.parallel ? s.threads : 1);
    wall_history = ApplyPairHistory(s);
    KeepReferencePositions(b, s.lists, s.parallel ? s.threads : 1);
    if (projectile)
      RebuildCandidateList(b, s.lists.grid, projectile->position, projectile->radius,
                           s.lists.max_radius, s.lists.skin, s.lists.near_projectile);
  }
  WeighBlocks(s);
  ListNearContainer(b, params.container, std::move(wall_history), s);
  if (projectile) s.lists.projectile_reference = projectile->position;
  s.lists.max_bead_displacement = 0.0;
  s.lists.displacement_before_sort = 0.0;
  s.lists.projectile_list_displacement = 0.0;
  s.lists.valid = true;
  ++s.lists.builds;
}

// Moves the far pairs that have come within the near gap into the near part, when one may
// have closed it, and takes the present positions as the reference for the next time; what
// the beads had moved is kept for the tests of the whole lists' age.
void SortFarPairs(const ParticleState& b, Simulation::Impl& s) {
  ResortPairList(b, s.lists.near_gap, s.lists.pairs, s.parallel ? s.threads : 1);
  s.lists.displacement_before_sort += s.lists.max_bead_displacement;
  s.lists.projectile_list_displacement += s.lists.max_bead_displacement;
  KeepReferencePositions(b, s.lists, s.parallel ? s.threads : 1);
  s.lists.max_bead_displacement = 0.0;
  ++s.lists.sorts;
}

// A fast projectile outruns its list long before the beads outrun theirs: rebuild only its
// candidates, from the bead grid of the last full build (beads have moved less than half a
// skin since, which the search box allows for).
void RebuildProjectileList(const ParticleState& b, const RigidSphere& projectile,
                           Simulation::Impl& s) {
  if (b.size() > 0)
    RebuildCandidateList(b, s.lists.grid, projectile.position, projectile.radius,
                         s.lists.max_radius, s.lists.skin, s.lists.near_projectile,
                         s.lists.DisplacementSinceBuild());
  s.lists.projectile_reference = projectile.position;
  s.lists.projectile_list_displacement = s.lists.max_bead_displacement;
}

// The bead lists stay valid while no pair can have closed the skin: two beads moving towards
// each other by at most d each.
bool BeadListsValid(const Simulation::Impl& s) {
  return s.lists.valid && 2.0 * s.lists.DisplacementSinceBuild() < s.lists.skin;
}

// Likewise the pair list's near part holds every touching pair while no far pair can have
// closed the near gap since the far pairs were last sorted.
bool NearPairsValid(const Simulation::Impl& s) {
  return 2.0 * s.lists.max_bead_displacement < s.lists.near_gap;
}

// The projectile's list stays valid while its own displacement plus a bead's since the list
// was built stays below the skin. A bead's displacement since then is at most its present
// displacement from the bead reference plus what it may have had from the reference when the
// list was built (grown at each sort of the pairs, which moves the reference).
bool ProjectileListValid(const RigidSphere& projectile, const Simulation::Impl& s) {
  const double moved = (projectile.position - s.lists.projectile_reference).norm();
  return moved + s.lists.max_bead_displacement + s.lists.projectile_list_displacement <
         s.lists.skin;
}

}  // namespace

void UpdateLists(const WorldParams& params, ParticleState& beads,
                 const std::optional<RigidSphere>& projectile, Simulation::Impl& s) {
  if (!BeadListsValid(s)) {
    RebuildLists(params, beads, projectile, s);
    return;
  }
  if (!NearPairsValid(s)) SortFarPairs(beads, s);
  if (projectile && !ProjectileListValid(*projectile, s))
    RebuildProjectileList(beads, *projectile, s);
}

}  // namespace dembuf::dem::detail
