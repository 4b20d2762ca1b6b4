#include "dembuf/core/neighbor_list.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <numeric>

namespace dembuf::dem::detail {

void CellGrid::Build(const std::vector<Vec3>& positions, double cell_size, const Vec3& lo,
                     const Vec3& hi) {
  m_lo = lo;
  m_inv_cell = 1.0 / cell_size;
  int space_dims[3];
  std::size_t cells = 1;
  for (int d = 0; d < 3; ++d) {
    space_dims[d] = std::max(1, static_cast<int>(std::ceil((hi[d] - lo[d]) * m_inv_cell)));
    cells *= space_dims[d];
  }
  // Layers across the axis with the most cells (z, then x, on ties): the more layers, the
  // thinner a layer, and the fewer the beads at the border between two threads' shares of
  // them, whose cache lines pass between the cores. A layer's rows are stacked along the axis
  // with the fewest cells, so that each row, the run a neighbor search visits at once, is long.
  int axes[3] = {2, 0, 1};
  std::stable_sort(axes, axes + 3, [&](int a, int b) { return space_dims[a] > space_dims[b]; });
  m_axis[2] = axes[0];
  m_axis[0] = axes[1];
  m_axis[1] = axes[2];
  for (int a = 0; a < 3; ++a) m_dims[a] = space_dims[m_axis[a]];
  const std::size_t n = positions.size();
  std::vector<std::uint32_t> bead_cell(n);  // a scratch: not kept between builds
  m_cell_start.assign(cells + 1, 0);
  for (std::size_t i = 0; i < n; ++i) {
    int c[3];
    CellCoords(positions[i], c);
    bead_cell[i] = static_cast<std::uint32_t>(Index(c[0], c[1], c[2]));
    ++m_cell_start[bead_cell[i] + 1];
  }
  for (std::size_t c = 0; c < cells; ++c) m_cell_start[c + 1] += m_cell_start[c];
  m_cell_beads.resize(n);
  std::vector<std::uint32_t> fill(m_cell_start.begin(), m_cell_start.end() - 1);
  for (std::size_t i = 0; i < n; ++i) m_cell_beads[fill[bead_cell[i]]++] = i;
}

namespace {

// Copies the history of entries present in both sorted id ranges: a two-pointer merge, so a
// rebuild costs O(entries) and never loses the shear of a contact that is still in the list.
void CarryHistory(const std::uint32_t* old_ids, const Vec3* old_shear, std::size_t old_count,
                  const std::uint32_t* new_ids, Vec3* new_shear, std::size_t new_count) {
  std::size_t a = 0;
  for (std::size_t b = 0; b < new_count; ++b) {
    while (a < old_count && old_ids[a] < new_ids[b]) ++a;
    new_shear[b] = (a < old_count && old_ids[a] == new_ids[b]) ? old_shear[a] : Vec3::Zero();
  }
}

}  // namespace

void RebuildPairList(const ParticleState& beads, const CellGrid& grid, double skin, double near_gap,
                     PairList& list, int threads) {
  // Beads are searched in fixed chunks, each into its own vectors, which are then joined in
  // chunk order: the same list for any number of threads.
  constexpr std::size_t kChunkBeads = 512;
  const std::size_t n = beads.size();
  const long chunks = static_cast<long>((n + kChunkBeads - 1) / kChunkBeads);
  const bool parallel = threads > 1 && chunks > 1;
  std::vector<std::vector<std::uint32_t>> found(chunks);
  std::vector<std::vector<std::uint32_t>> found_far(chunks);
  // Beads numbered in cell order (large beds are kept so) have all their partners j > i in
  // the forward half of the cells around them.
  const bool forward = grid.InCellOrder();
  PairList fresh;
  fresh.offsets.resize(n + 1);
  fresh.far_offsets.resize(n + 1);
#pragma omp parallel for schedule(dynamic) num_threads(threads) if (parallel)
  for (long c = 0; c < chunks; ++c) {
    const std::size_t first = c * kChunkBeads, last = std::min(n, first + kChunkBeads);
    std::vector<std::uint32_t>& partners = found[c];
    std::vector<std::uint32_t>& far = found_far[c];
    partners.reserve(16 * (last - first));
    far.reserve(8 * (last - first));
    for (std::size_t i = first; i < last; ++i) {
      const std::size_t bead_first = partners.size();
      fresh.offsets[i] = static_cast<std::uint32_t>(bead_first);  // within the chunk
      fresh.far_offsets[i] = static_cast<std::uint32_t>(far.size());
      const Vec3 xi = beads.position[i];
      const double ri = beads.radius[i];
      if (forward) {
        // Ids are positions in cell order: each run holds consecutive ids, the runs come in
        // increasing order (so the partners come sorted), and j > i skips the start of the
        // first run. Every candidate is written and the count advances by the test's result:
        // no branch to mispredict.
        grid.ForEachForwardRun(xi, [&](std::uint32_t run_first, std::uint32_t run_last) {
          const std::uint32_t from = std::max<std::uint32_t>(run_first, i + 1);
          if (from >= run_last) return;
          std::size_t count = partners.size();
          partners.resize(count + (run_last - from));
          for (std::uint32_t j = from; j < run_last; ++j) {
            const double reach = ri + beads.radius[j] + skin;
            partners[count] = j;
            count += (xi - beads.position[j]).squaredNorm() < reach * reach;
          }
          partners.resize(count);
        });
      } else {
        grid.ForEachAround(xi, [&](std::uint32_t j) {
          if (j <= i) return;
          const double reach = ri + beads.radius[j] + skin;
          if ((xi - beads.position[j]).squaredNorm() < reach * reach) partners.push_back(j);
        });
        std::sort(partners.begin() + bead_first, partners.end());
      }
      // Two held beads (inv_mass 0: neither moves nor turns) can change nothing by touching:
      // their pair is left out, which spares local settling the held rim of its region.
      if (beads.inv_mass[i] == 0.0)
        partners.erase(std::remove_if(partners.begin() + bead_first, partners.end(),
                                      [&](std::uint32_t j) { return beads.inv_mass[j] == 0.0; }),
                       partners.end());
      // The near pairs close up in place, the others go to the far part (both written, each
      // count advanced by the test: no branch).
      std::size_t near_count = bead_first, far_count = far.size();
      far.resize(far_count + (partners.size() - bead_first));
      for (std::size_t k = bead_first; k < partners.size(); ++k) {
        const std::uint32_t j = partners[k];
        const double near_reach = ri + beads.radius[j] + near_gap;
        const bool near = (xi - beads.position[j]).squaredNorm() < near_reach * near_reach;
        partners[near_count] = j;
        far[far_count] = j;
        near_count += near;
        far_count += !near;
      }
      partners.resize(near_count);
      far.resize(far_count);
    }
  }
  std::vector<std::uint32_t> chunk_start(chunks + 1, 0), far_start(chunks + 1, 0);
  for (long c = 0; c < chunks; ++c) {
    chunk_start[c + 1] = chunk_start[c] + static_cast<std::uint32_t>(found[c].size());
    far_start[c + 1] = far_start[c] + static_cast<std::uint32_t>(found_far[c].size());
  }
  fresh.offsets[n] = chunk_start[chunks];
  fresh.far_offsets[n] = far_start[chunks];
  fresh.partners.resize(chunk_start[chunks]);
  fresh.shear.resize(chunk_start[chunks]);
  fresh.far_partners.resize(far_start[chunks]);

  const bool had_list = list.offsets.size() == n + 1;
#pragma omp parallel for schedule(dynamic) num_threads(threads) if (parallel)
  for (long c = 0; c < chunks; ++c) {
    const std::size_t first = c * kChunkBeads, last = std::min(n, first + kChunkBeads);
    std::copy(found[c].begin(), found[c].end(), fresh.partners.begin() + chunk_start[c]);
    std::copy(found_far[c].begin(), found_far[c].end(), fresh.far_partners.begin() + far_start[c]);
    for (std::size_t i = first; i < last; ++i) {
      fresh.offsets[i] += chunk_start[c];
      fresh.far_offsets[i] += far_start[c];
    }
    for (std::size_t i = first; i < last; ++i) {
      // The next chunk's offsets may not be shifted yet: its first entry is chunk_start[c + 1].
      const std::uint32_t b0 = fresh.offsets[i];
      const std::uint32_t b1 = i + 1 < last ? fresh.offsets[i + 1] : chunk_start[c + 1];
      if (!had_list) {
        std::fill(fresh.shear.begin() + b0, fresh.shear.begin() + b1, Vec3::Zero());
        continue;
      }
      // Only near pairs have histories, and a pair that was near is in the list again.
      const std::uint32_t a0 = list.offsets[i], a1 = list.offsets[i + 1];
      CarryHistory(list.partners.data() + a0, list.shear.data() + a0, a1 - a0,
                   fresh.partners.data() + b0, fresh.shear.data() + b0, b1 - b0);
    }
  }
  list = std::move(fresh);
}

void ResortPairList(const ParticleState& beads, double near_gap, PairList& list, int threads) {
  const std::size_t n = beads.size();
  if (list.offsets.size() != n + 1) return;  // nothing listed yet
  const Vec3* x = beads.position.data();
  const double* r = beads.radius.data();
  const std::uint32_t* far_offsets = list.far_offsets.data();
  std::uint32_t* far = list.far_partners.data();
  const std::uint32_t entries = far_offsets[n];

  // 1. Which far pairs are now near: the distances, the costly part, in fixed chunks of beads
  // on the threads (each entry's flag is the same whoever computes it), with each chunk's count
  // of pairs kept far.
  constexpr std::size_t kChunkBeads = 512;
  const long chunks = static_cast<long>((n + kChunkBeads - 1) / kChunkBeads);
  const bool parallel = threads > 1 && chunks > 1;
  auto chunk_beads = [&](long c) {
    return std::pair{c * kChunkBeads, std::min(n, (c + 1) * kChunkBeads)};
  };
  std::vector<std::uint8_t> now_near(entries);
  std::vector<std::uint32_t> kept_in(chunks + 1, 0), taken_in(chunks + 1, 0);
#pragma omp parallel for schedule(static) num_threads(threads) if (parallel)
  for (long c = 0; c < chunks; ++c) {
    const auto [first, last] = chunk_beads(c);
    std::uint32_t taken = 0;
    for (std::size_t i = first; i < last; ++i)
      for (std::uint32_t k = far_offsets[i]; k < far_offsets[i + 1]; ++k) {
        const std::uint32_t j = far[k];
        const double reach = r[i] + r[j] + near_gap;
        now_near[k] = (x[i] - x[j]).squaredNorm() < reach * reach;
        taken += now_near[k];
      }
    taken_in[c + 1] = taken;
    kept_in[c + 1] = far_offsets[last] - far_offsets[first] - taken;
  }
  // Where each chunk's kept and taken entries go: the counts of the chunks before it.
  std::partial_sum(kept_in.begin(), kept_in.end(), kept_in.begin());
  std::partial_sum(taken_in.begin(), taken_in.end(), taken_in.begin());
  const std::uint32_t kept = kept_in[chunks];
  const std::size_t promoted = taken_in[chunks];

  // 2. The far pairs now near are taken out, in bead and partner order, and the others close
  // up: each chunk within its own entries on the threads (the writes never pass the reads, and
  // chunks do not share entries), then the chunks' kept entries move down in order, one after
  // the other (their new places may overlap the chunk before's old ones).
  std::vector<std::uint32_t> new_far_offsets(n + 1);
  std::vector<std::uint32_t> promoted_bead(promoted), promoted_partner(promoted);
#pragma omp parallel for schedule(static) num_threads(threads) if (parallel)
  for (long c = 0; c < chunks; ++c) {
    const auto [first, last] = chunk_beads(c);
    const std::uint32_t start = far_offsets[first];
    std::uint32_t write = start;
    std::size_t taken = taken_in[c];
    for (std::size_t i = first; i < last; ++i) {
      new_far_offsets[i] = kept_in[c] + (write - start);
      for (std::uint32_t k = far_offsets[i]; k < far_offsets[i + 1]; ++k) {
        if (now_near[k]) {
          promoted_bead[taken] = static_cast<std::uint32_t>(i);
          promoted_partner[taken++] = far[k];
        } else {
          far[write++] = far[k];
        }
      }
    }
  }
  for (long c = 1; c < chunks; ++c) {
    const std::uint32_t from = far_offsets[chunk_beads(c).first];
    // (An empty far part may have no storage at all: memmove takes no null pointer.)
    if (kept_in[c + 1] > kept_in[c])
      std::memmove(far + kept_in[c], far + from, (kept_in[c + 1] - kept_in[c]) * sizeof *far);
  }
  new_far_offsets[n] = kept;
  list.far_offsets = std::move(new_far_offsets);
  list.far_partners.resize(kept);

  // 3. They join the near part in bead and partner order, without history: a merge from the
  // back, in place. (Near pairs that have come apart stay near until the next build: they
  // cost the force pass a check each, and taking them out costs a pass over all near pairs.)
  if (promoted == 0) return;
  std::uint32_t* offsets = list.offsets.data();
  std::size_t read = offsets[n], write = offsets[n] + promoted;  // one past the next to move
  list.partners.resize(write);
  list.shear.resize(write);
  std::uint32_t* partners = list.partners.data();
  Vec3* shear = list.shear.data();
  for (std::size_t p = promoted; p-- > 0;) {
    const std::uint32_t bead = promoted_bead[p], partner = promoted_partner[p];
    // The entries of later beads move as a block, then the bead's own partners after it.
    const std::size_t bead_end = offsets[bead + 1], bead_start = offsets[bead];
    if (read > bead_end) {
      std::move_backward(partners + bead_end, partners + read, partners + write);
      std::move_backward(shear + bead_end, shear + read, shear + write);
      write -= read - bead_end;
      read = bead_end;
    }
    while (read > bead_start && partners[read - 1] > partner) {
      --read;
      --write;
      partners[write] = partners[read];
      shear[write] = shear[read];
    }
    --write;
    partners[write] = partner;
    shear[write] = Vec3::Zero();
  }
  // Each bead's entries start later by the promoted pairs of the beads before it.
  std::size_t before = 0;
  for (std::size_t i = 0; i <= n; ++i) {
    while (before < promoted && promoted_bead[before] < i) ++before;
    offsets[i] += static_cast<std::uint32_t>(before);
  }
}

void RebuildCandidateList(const ParticleState& beads, const CellGrid& grid, const Vec3& center,
                          double radius, double max_bead_radius, double skin, CandidateList& list,
                          double grid_age_margin) {
  const Vec3 half = Vec3::Constant(radius + max_bead_radius + skin + grid_age_margin);
  std::vector<std::uint32_t> ids;
  grid.ForEachInBox(center - half, center + half, [&](std::uint32_t j) {
    const double reach = radius + beads.radius[j] + skin;
    if ((center - beads.position[j]).squaredNorm() < reach * reach) ids.push_back(j);
  });
  std::sort(ids.begin(), ids.end());
  std::vector<Vec3> shear(ids.size());
  CarryHistory(list.beads.data(), list.shear.data(), list.beads.size(), ids.data(), shear.data(),
               ids.size());
  list.beads = std::move(ids);
  list.shear = std::move(shear);
}

}  // namespace dembuf::dem::detail
