// Neighbor search: a cell grid sized by the beads, a Verlet half list with skin that carries
// the contact history beside each entry, and a separate candidate list for the projectile so
// that one large body does not force large cells on everyone.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "dembuf/core/particles.h"

namespace dembuf::dem::detail {

/// Beads binned into cubic cells (counting sort). Points outside the grid are clamped into
/// its border cells, which stays correct (only the candidate count grows).
class CellGrid {
 public:
  void Build(const std::vector<Vec3>& positions, double cell_size, const Vec3& lo, const Vec3& hi);

  /// Bytes its arrays hold (their capacity).
  std::size_t MemoryBytes() const {
    return (m_cell_start.capacity() + m_cell_beads.capacity()) * sizeof(std::uint32_t);
  }

  /// Calls visit(j) for every bead in the cells overlapping the box [lo, hi].
  template <class Visit>
  void ForEachInBox(const Vec3& lo, const Vec3& hi, Visit&& visit) const {
    int a[3], b[3];
    CellCoords(lo, a);
    CellCoords(hi, b);
    for (int z = a[2]; z <= b[2]; ++z)
      for (int y = a[1]; y <= b[1]; ++y)
        for (int x = a[0]; x <= b[0]; ++x) {
          const std::size_t c = Index(x, y, z);
          for (std::uint32_t k = m_cell_start[c]; k < m_cell_start[c + 1]; ++k)
            visit(m_cell_beads[k]);
        }
  }

  /// Bead ids in cell order: layer by layer, row by row, cell by cell. Sorting beads this
  /// way keeps neighbors close in memory and groups them in layers. The cell coordinates
  /// below are in this order (0: along a row, 1: rows of a layer, 2: layers).
  const std::vector<std::uint32_t>& CellOrder() const { return m_cell_beads; }

  /// The space axis (0: x, 1: y, 2: z) of cell axis a. The layers are slices across the
  /// grid's longest axis: a bed in the paper's cylinder, wider than deep, is cut into
  /// vertical slices; a tall column into horizontal layers.
  int SpaceAxis(int a) const { return m_axis[a]; }

  /// Number of cells along cell axis a.
  int Dim(int a) const { return m_dims[a]; }

  /// Index (in cell order) of the first bead of the row of cells (y, z); y = Dim(1) is the
  /// first row of layer z + 1, and z = Dim(2) one past the last bead.
  std::uint32_t RowStart(int y, int z) const { return m_cell_start[Index(0, y, z)]; }

  /// Calls visit(j) for every bead in the 27 cells around the cell of point p.
  template <class Visit>
  void ForEachAround(const Vec3& p, Visit&& visit) const {
    ForEachRunInStencil<false>(p, [&](std::uint32_t first, std::uint32_t last) {
      for (std::uint32_t k = first; k < last; ++k) visit(m_cell_beads[k]);
    });
  }

  /// The cell of point p and those of the 27 around it that come after it in cell order (13),
  /// as runs [first, last) of positions in cell order (CellOrder()), one per row of cells, in
  /// increasing order. When the beads are numbered in cell order, positions are ids, and these
  /// runs hold all the neighbors j > i of a bead i at p (with i and the ids before it in its
  /// own cell): half the cells of ForEachAround.
  template <class VisitRun>
  void ForEachForwardRun(const Vec3& p, VisitRun&& visit_run) const {
    ForEachRunInStencil<true>(p, visit_run);
  }

  /// True when the beads are numbered in cell order (CellOrder() is 0, 1, 2, ...).
  bool InCellOrder() const {
    for (std::size_t k = 0; k < m_cell_beads.size(); ++k)
      if (m_cell_beads[k] != k) return false;
    return true;
  }

 private:
  void CellCoords(const Vec3& p, int out[3]) const {
    for (int a = 0; a < 3; ++a) {
      const int d = m_axis[a];
      double s = (p[d] - m_lo[d]) * m_inv_cell;
      int c = s > 0.0 ? static_cast<int>(s) : 0;  // also maps NaN to 0
      out[a] = c < m_dims[a] ? c : m_dims[a] - 1;
    }
  }
  std::size_t Index(int x, int y, int z) const {
    return (static_cast<std::size_t>(z) * m_dims[1] + y) * m_dims[0] + x;
  }

  // The 27 cells around the cell of p, or (kForward) only the cell and those after it (the
  // rows of the layers above, the rows after it in its layer, and the rest of its own row), as
  // runs [first, last) of positions in cell order, one per row of cells, in increasing order.
  template <bool kForward, class VisitRun>
  void ForEachRunInStencil(const Vec3& p, VisitRun&& visit_run) const {
    int c[3];
    CellCoords(p, c);
    const int x0 = c[0] > 0 ? c[0] - 1 : 0, x1 = c[0] + 1 < m_dims[0] ? c[0] + 1 : c[0];
    const int y0 = c[1] > 0 ? c[1] - 1 : 0, y1 = c[1] + 1 < m_dims[1] ? c[1] + 1 : c[1];
    const int z0 = c[2] > 0 ? c[2] - 1 : 0, z1 = c[2] + 1 < m_dims[2] ? c[2] + 1 : c[2];
    for (int z = kForward ? c[2] : z0; z <= z1; ++z)
      for (int y = kForward && z == c[2] ? c[1] : y0; y <= y1; ++y) {
        const std::size_t row = Index(0, y, z);
        const int first = kForward && z == c[2] && y == c[1] ? c[0] : x0;
        visit_run(m_cell_start[row + first], m_cell_start[row + x1 + 1]);
      }
  }

  Vec3 m_lo = Vec3::Zero();
  double m_inv_cell = 1.0;
  int m_dims[3] = {1, 1, 1};                // per cell axis
  int m_axis[3] = {0, 1, 2};                // space axis of each cell axis
  std::vector<std::uint32_t> m_cell_start;  // size cells + 1
  std::vector<std::uint32_t> m_cell_beads;  // bead ids ordered by cell
};

/// Half neighbor list in two parts, each in CSR form. The near part holds the pairs whose
/// gap was below the near gap when the list was built or last sorted (RebuildPairList,
/// ResortPairList): the partners j > i of bead i are partners[offsets[i] .. offsets[i+1]),
/// sorted, and shear[k] is the tangential history of entry k. The far part holds the other
/// pairs within the skin, likewise in far_offsets and far_partners, without histories: they
/// are apart. Every touching pair is in the near part while no bead has moved half the near
/// gap since the sort, so the force pass checks only those: in a settled bed half the pairs
/// within 0.2 diameters touch and a quarter are farther apart than 0.05 diameters, and a
/// wide skin, which spares list builds, costs the force pass nothing. Nothing else is kept
/// per entry (the force pass finds each entry's bead from the offsets and computes sqrt(R*)
/// from the radii): the entries are most of a simulation's memory.
struct PairList {
  std::vector<std::uint32_t> offsets;
  std::vector<std::uint32_t> partners;
  std::vector<Vec3> shear;
  std::vector<std::uint32_t> far_offsets;
  std::vector<std::uint32_t> far_partners;
};

/// Rebuilds `list` for all pairs closer than r_i + r_j + skin, but those of two held beads
/// (inv_mass 0), keeping the history of the near pairs already present: those closer than
/// r_i + r_j + near_gap form the near part. The result does not depend on `threads`.
void RebuildPairList(const ParticleState& beads, const CellGrid& grid, double skin, double near_gap,
                     PairList& list, int threads = 1);

/// Moves the far pairs of `list` that are now closer than r_i + r_j + near_gap into its near
/// part (without history), in place. The near pairs stay, history and all. The far pairs'
/// distances are tested on `threads` threads; the result does not depend on them.
void ResortPairList(const ParticleState& beads, double near_gap, PairList& list, int threads = 1);

/// Beads that may touch the projectile (sorted ids) and the history of each contact.
struct CandidateList {
  std::vector<std::uint32_t> beads;
  std::vector<Vec3> shear;
};

/// Rebuilds the projectile's candidates: beads closer than R + r_i + skin, in id order. The
/// grid may be older than the positions if no bead has moved more than `grid_age_margin`
/// since it was built.
void RebuildCandidateList(const ParticleState& beads, const CellGrid& grid, const Vec3& center,
                          double radius, double max_bead_radius, double skin, CandidateList& list,
                          double grid_age_margin = 0.0);

}  // namespace dembuf::dem::detail
