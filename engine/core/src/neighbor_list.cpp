#include "dembuf/core/neighbor_list.h"

#include <algorithm>
#include <cmath>

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

void RebuildPairList(const ParticleState& beads, const CellGrid& grid, double skin, PairList& list,
                     int threads) {
  // Beads are searched in fixed chunks, each into its own partner vector, which are then
  // joined in chunk order: the same list for any number of threads.
  constexpr std::size_t kChunkBeads = 512;
  const std::size_t n = beads.size();
  const long chunks = static_cast<long>((n + kChunkBeads - 1) / kChunkBeads);
  const bool parallel = threads > 1 && chunks > 1;
  std::vector<std::vector<std::uint32_t>> found(chunks);
  // Beads numbered in cell order (large beds are kept so) have all their partners j > i in
  // the forward half of the cells around them.
  const bool forward = grid.InCellOrder();
  PairList fresh;
  fresh.offsets.resize(n + 1);
#pragma omp parallel for schedule(dynamic) num_threads(threads) if (parallel)
  for (long c = 0; c < chunks; ++c) {
    const std::size_t first = c * kChunkBeads, last = std::min(n, first + kChunkBeads);
    std::vector<std::uint32_t>& partners = found[c];
    partners.reserve(8 * (last - first));
    for (std::size_t i = first; i < last; ++i) {
      fresh.offsets[i] = static_cast<std::uint32_t>(partners.size());  // within the chunk
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
        std::sort(partners.begin() + fresh.offsets[i], partners.end());
      }
      // Two held beads (inv_mass 0: neither moves nor turns) can change nothing by touching:
      // their pair is left out, which spares local settling the held rim of its region.
      if (beads.inv_mass[i] == 0.0)
        partners.erase(std::remove_if(partners.begin() + fresh.offsets[i], partners.end(),
                                      [&](std::uint32_t j) { return beads.inv_mass[j] == 0.0; }),
                       partners.end());
    }
  }
  std::vector<std::uint32_t> chunk_start(chunks + 1, 0);
  for (long c = 0; c < chunks; ++c)
    chunk_start[c + 1] = chunk_start[c] + static_cast<std::uint32_t>(found[c].size());
  fresh.offsets[n] = chunk_start[chunks];
  fresh.partners.resize(chunk_start[chunks]);
  fresh.shear.resize(chunk_start[chunks]);

  const bool had_list = list.offsets.size() == n + 1;
#pragma omp parallel for schedule(dynamic) num_threads(threads) if (parallel)
  for (long c = 0; c < chunks; ++c) {
    const std::size_t first = c * kChunkBeads, last = std::min(n, first + kChunkBeads);
    std::copy(found[c].begin(), found[c].end(), fresh.partners.begin() + chunk_start[c]);
    for (std::size_t i = first; i < last; ++i) fresh.offsets[i] += chunk_start[c];
    for (std::size_t i = first; i < last; ++i) {
      // The next chunk's offsets may not be shifted yet: its first entry is chunk_start[c + 1].
      const std::uint32_t b0 = fresh.offsets[i];
      const std::uint32_t b1 = i + 1 < last ? fresh.offsets[i + 1] : chunk_start[c + 1];
      if (!had_list) {
        std::fill(fresh.shear.begin() + b0, fresh.shear.begin() + b1, Vec3::Zero());
        continue;
      }
      const std::uint32_t a0 = list.offsets[i], a1 = list.offsets[i + 1];
      CarryHistory(list.partners.data() + a0, list.shear.data() + a0, a1 - a0,
                   fresh.partners.data() + b0, fresh.shear.data() + b0, b1 - b0);
    }
  }
  list = std::move(fresh);
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
