// The Verlet list finds every pair within reach, and history survives rebuilds.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <set>

#include "dembuf/core/neighbor_list.h"

namespace dembuf::dem::detail {
namespace {

// n beads of radius 2 to 2.5 mm at random in the box [lo, hi], overlaps allowed.
dem::ParticleState RandomBeads(int n, std::uint64_t seed,
                               const dem::Vec3& lo = dem::Vec3(-0.05, -0.05, 0.0),
                               const dem::Vec3& hi = dem::Vec3(0.05, 0.05, 0.05)) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> x(lo.x(), hi.x()), y(lo.y(), hi.y()), z(lo.z(), hi.z()),
      r(0.002, 0.0025);
  dem::ParticleState b;
  for (int i = 0; i < n; ++i) b.Add(dem::Vec3(x(rng), y(rng), z(rng)), r(rng), 2650.0);
  return b;
}

// The ids of the beads within reach of a sphere (centre c, radius R), in id order.
std::vector<std::uint32_t> CandidatesByBruteForce(const dem::ParticleState& b, const dem::Vec3& c,
                                                  double R, double skin) {
  std::vector<std::uint32_t> ids;
  for (std::uint32_t j = 0; j < b.size(); ++j)
    if ((b.position[j] - c).norm() < R + b.radius[j] + skin) ids.push_back(j);
  return ids;
}

// The list holds exactly the pairs i < j within reach, partners sorted; returns their count.
std::size_t ExpectMatchesBruteForce(const dem::ParticleState& b, const PairList& list,
                                    double skin) {
  std::set<std::pair<std::uint32_t, std::uint32_t>> found, expected;
  for (std::uint32_t i = 0; i < b.size(); ++i) {
    for (std::uint32_t k = list.offsets[i]; k < list.offsets[i + 1]; ++k) {
      EXPECT_GT(list.partners[k], i);
      if (k > list.offsets[i]) {
        EXPECT_LT(list.partners[k - 1], list.partners[k]);
      }
      found.insert({i, list.partners[k]});
    }
    for (std::uint32_t j = i + 1; j < b.size(); ++j) {
      const double reach = b.radius[i] + b.radius[j] + skin;
      if ((b.position[i] - b.position[j]).squaredNorm() < reach * reach) expected.insert({i, j});
    }
  }
  EXPECT_EQ(found, expected);
  return expected.size();
}

TEST(PairList, MatchesBruteForce) {
  const dem::ParticleState b = RandomBeads(2000, 7);
  const double skin = 0.0008;
  CellGrid grid;
  grid.Build(b.position, 0.005 + skin, dem::Vec3(-0.06, -0.06, -0.005),
             dem::Vec3(0.06, 0.06, 0.03));
  ASSERT_FALSE(grid.InCellOrder());  // the search over all 27 cells around each bead
  PairList list;
  RebuildPairList(b, grid, skin, list);
  // Built in chunks on several threads (2000 beads are four chunks), the list is the same.
  for (int threads : {2, 3}) {
    PairList parallel;
    RebuildPairList(b, grid, skin, parallel, threads);
    EXPECT_EQ(parallel.offsets, list.offsets) << threads << " threads";
    EXPECT_EQ(parallel.partners, list.partners) << threads << " threads";
  }
  // The grid is shorter than the beads' z range: clamping works.
  EXPECT_GT(ExpectMatchesBruteForce(b, list, skin), 1000u);
}

TEST(PairList, BeadsInCellOrderSearchHalfTheCellsAndMatchBruteForce) {
  const dem::ParticleState random = RandomBeads(2000, 11);
  const double skin = 0.0008;
  const dem::Vec3 lo(-0.06, -0.06, -0.005), hi(0.06, 0.06, 0.03);
  CellGrid grid;
  grid.Build(random.position, 0.005 + skin, lo, hi);
  dem::ParticleState b;  // the same beads numbered in cell order, as large beds are kept
  for (std::uint32_t i : grid.CellOrder()) b.Add(random.position[i], random.radius[i], 2650.0);
  grid.Build(b.position, 0.005 + skin, lo, hi);
  ASSERT_TRUE(grid.InCellOrder());  // the search over the forward half of the cells
  PairList list;
  RebuildPairList(b, grid, skin, list, 2);
  EXPECT_GT(ExpectMatchesBruteForce(b, list, skin), 1000u);
}

TEST(CellGrid, LayersAreSlicesAcrossTheLongestAxis) {
  const double cell = 0.0058;  // d_max + skin of the paper's beads
  CellGrid bed;                // the paper's cylinder, a 9 cm bed: 35 x 35 x 19 cells
  bed.Build({}, cell, dem::Vec3(-0.1, -0.1, -0.005), dem::Vec3(0.1, 0.1, 0.1));
  EXPECT_EQ(bed.SpaceAxis(2), 0);  // vertical slices across x (x before y on ties)
  EXPECT_EQ(bed.SpaceAxis(1), 2);  // rows of cells stacked along z, the shortest axis
  EXPECT_EQ(bed.SpaceAxis(0), 1);  // each row along y
  EXPECT_EQ(bed.Dim(2), 35);
  EXPECT_EQ(bed.Dim(1), 19);
  CellGrid wide;  // 69 x 35 x 5 cells
  wide.Build({}, cell, dem::Vec3(-0.2, -0.1, -0.005), dem::Vec3(0.2, 0.1, 0.02));
  EXPECT_EQ(wide.SpaceAxis(2), 0);
  CellGrid deep;  // 69 x 73 x 5 cells: slices across y
  deep.Build({}, cell, dem::Vec3(-0.2, -0.21, -0.005), dem::Vec3(0.2, 0.21, 0.02));
  EXPECT_EQ(deep.SpaceAxis(2), 1);
  CellGrid tall;  // a column taller than wide: horizontal layers, rows along y
  tall.Build({}, cell, dem::Vec3(-0.1, -0.1, -0.005), dem::Vec3(0.1, 0.1, 0.5));
  EXPECT_EQ(tall.SpaceAxis(2), 2);
  EXPECT_EQ(tall.SpaceAxis(1), 1);
  EXPECT_EQ(tall.SpaceAxis(0), 0);
}

TEST(PairList, BeadsInSliceOrderSearchHalfTheCellsAndMatchBruteForce) {
  const dem::ParticleState random =
      RandomBeads(4000, 5, dem::Vec3(-0.2, -0.1, 0.0), dem::Vec3(0.2, 0.1, 0.02));
  const double skin = 0.0008;
  const dem::Vec3 lo(-0.2, -0.1, -0.005), hi(0.2, 0.1, 0.025);
  CellGrid grid;
  grid.Build(random.position, 0.005 + skin, lo, hi);
  ASSERT_EQ(grid.SpaceAxis(2), 0);
  dem::ParticleState b;
  for (std::uint32_t i : grid.CellOrder()) b.Add(random.position[i], random.radius[i], 2650.0);
  grid.Build(b.position, 0.005 + skin, lo, hi);
  ASSERT_TRUE(grid.InCellOrder());
  for (std::uint32_t i = 1; i < b.size(); ++i)  // slices follow each other along x
    ASSERT_LE(std::floor((b.position[i - 1].x() - lo.x()) / (0.005 + skin)),
              std::floor((b.position[i].x() - lo.x()) / (0.005 + skin)));
  PairList list;
  RebuildPairList(b, grid, skin, list, 2);
  EXPECT_GT(ExpectMatchesBruteForce(b, list, skin), 2000u);
  // The box search of the projectile's candidates sees the same axes.
  CandidateList near;
  const dem::Vec3 c(0.05, -0.02, 0.01);
  RebuildCandidateList(b, grid, c, 0.025, 0.0025, skin, near);
  const std::vector<std::uint32_t> expected = CandidatesByBruteForce(b, c, 0.025, skin);
  EXPECT_EQ(near.beads, expected);
  EXPECT_GT(expected.size(), 20u);
}

TEST(PairList, RebuildKeepsHistoryOfSurvivingPairs) {
  for (int threads : {1, 2}) {  // 1500 beads: three chunks, carried across chunk borders
    dem::ParticleState b = RandomBeads(1500, 3);
    const double skin = 0.001;
    CellGrid grid;
    grid.Build(b.position, 0.005 + skin, dem::Vec3(-0.06, -0.06, -0.005),
               dem::Vec3(0.06, 0.06, 0.06));
    PairList list;
    RebuildPairList(b, grid, skin, list, threads);
    for (std::uint32_t i = 0; i < b.size(); ++i)
      for (std::uint32_t k = list.offsets[i]; k < list.offsets[i + 1]; ++k)
        list.shear[k] = dem::Vec3(i, list.partners[k], 1.0);
    // Move one bead far away: its pairs vanish, every other pair keeps its stamp.
    b.position[10] = dem::Vec3(0.0, 0.0, 0.055);
    grid.Build(b.position, 0.005 + skin, dem::Vec3(-0.06, -0.06, -0.005),
               dem::Vec3(0.06, 0.06, 0.06));
    RebuildPairList(b, grid, skin, list, threads);
    std::size_t kept = 0;
    for (std::uint32_t i = 0; i < b.size(); ++i)
      for (std::uint32_t k = list.offsets[i]; k < list.offsets[i + 1]; ++k) {
        const std::uint32_t j = list.partners[k];
        if (i == 10 || j == 10) {
          EXPECT_EQ(list.shear[k], dem::Vec3::Zero());
        } else {
          EXPECT_EQ(list.shear[k], dem::Vec3(i, j, 1.0)) << threads << " threads";
          ++kept;
        }
      }
    EXPECT_GT(kept, 1000u);
  }
}

TEST(CandidateList, FindsBeadsNearALargeSphere) {
  const dem::ParticleState b = RandomBeads(2000, 11);
  const double skin = 0.0008;
  CellGrid grid;
  grid.Build(b.position, 0.005 + skin, dem::Vec3(-0.06, -0.06, -0.005),
             dem::Vec3(0.06, 0.06, 0.06));
  CandidateList near;
  const dem::Vec3 c(0.01, -0.005, 0.03);
  RebuildCandidateList(b, grid, c, 0.025, 0.0025, skin, near);
  const std::vector<std::uint32_t> expected = CandidatesByBruteForce(b, c, 0.025, skin);
  EXPECT_EQ(near.beads, expected);
  EXPECT_EQ(near.shear.size(), expected.size());
}

}  // namespace
}  // namespace dembuf::dem::detail
