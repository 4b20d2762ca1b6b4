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

using PairSet = std::set<std::pair<std::uint32_t, std::uint32_t>>;

// The pairs of one part of a pair list; checks that bead i's partners are j > i, sorted.
PairSet PartPairs(const std::vector<std::uint32_t>& offsets,
                  const std::vector<std::uint32_t>& partners, std::size_t beads) {
  PairSet found;
  EXPECT_EQ(offsets.size(), beads + 1);
  EXPECT_EQ(offsets.back(), partners.size());
  for (std::uint32_t i = 0; i < beads; ++i)
    for (std::uint32_t k = offsets[i]; k < offsets[i + 1]; ++k) {
      EXPECT_GT(partners[k], i);
      if (k > offsets[i]) {
        EXPECT_LT(partners[k - 1], partners[k]);
      }
      found.insert({i, partners[k]});
    }
  return found;
}
PairSet NearPairs(const PairList& list, std::size_t beads) {
  EXPECT_EQ(list.shear.size(), list.partners.size());
  return PartPairs(list.offsets, list.partners, beads);
}
PairSet FarPairs(const PairList& list, std::size_t beads) {
  return PartPairs(list.far_offsets, list.far_partners, beads);
}

// The list holds exactly the pairs i < j within reach, those within the near gap in its near
// part (partners sorted) and the others in its far part; returns their count.
std::size_t ExpectMatchesBruteForce(const dem::ParticleState& b, const PairList& list, double skin,
                                    double near_gap) {
  PairSet expected_near, expected_far;
  for (std::uint32_t i = 0; i < b.size(); ++i)
    for (std::uint32_t j = i + 1; j < b.size(); ++j) {
      const double dist2 = (b.position[i] - b.position[j]).squaredNorm();
      const double near_reach = b.radius[i] + b.radius[j] + near_gap;
      const double reach = b.radius[i] + b.radius[j] + skin;
      if (dist2 < near_reach * near_reach)
        expected_near.insert({i, j});
      else if (dist2 < reach * reach)
        expected_far.insert({i, j});
    }
  EXPECT_EQ(NearPairs(list, b.size()), expected_near);
  EXPECT_EQ(FarPairs(list, b.size()), expected_far);
  return expected_near.size() + expected_far.size();
}

TEST(PairList, MatchesBruteForce) {
  const dem::ParticleState b = RandomBeads(2000, 7);
  const double skin = 0.0008;
  CellGrid grid;
  grid.Build(b.position, 0.005 + skin, dem::Vec3(-0.06, -0.06, -0.005),
             dem::Vec3(0.06, 0.06, 0.03));
  ASSERT_FALSE(grid.InCellOrder());  // the search over all 27 cells around each bead
  const double near_gap = 0.25 * skin;
  PairList list;
  RebuildPairList(b, grid, skin, near_gap, list);
  // Built in chunks on several threads (2000 beads are four chunks), the list is the same.
  for (int threads : {2, 3}) {
    PairList parallel;
    RebuildPairList(b, grid, skin, near_gap, parallel, threads);
    EXPECT_EQ(parallel.offsets, list.offsets) << threads << " threads";
    EXPECT_EQ(parallel.partners, list.partners) << threads << " threads";
    EXPECT_EQ(parallel.far_offsets, list.far_offsets) << threads << " threads";
    EXPECT_EQ(parallel.far_partners, list.far_partners) << threads << " threads";
  }
  // The grid is shorter than the beads' z range: clamping works.
  EXPECT_GT(ExpectMatchesBruteForce(b, list, skin, near_gap), 1000u);
  EXPECT_GT(list.far_partners.size(), 100u);
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
  RebuildPairList(b, grid, skin, 0.25 * skin, list, 2);
  EXPECT_GT(ExpectMatchesBruteForce(b, list, skin, 0.25 * skin), 1000u);
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
  RebuildPairList(b, grid, skin, 0.25 * skin, list, 2);
  EXPECT_GT(ExpectMatchesBruteForce(b, list, skin, 0.25 * skin), 2000u);
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
    RebuildPairList(b, grid, skin, /*near_gap=*/skin, list, threads);
    for (std::uint32_t i = 0; i < b.size(); ++i)
      for (std::uint32_t k = list.offsets[i]; k < list.offsets[i + 1]; ++k)
        list.shear[k] = dem::Vec3(i, list.partners[k], 1.0);
    // Move one bead far away: its pairs vanish, every other pair keeps its stamp.
    b.position[10] = dem::Vec3(0.0, 0.0, 0.055);
    grid.Build(b.position, 0.005 + skin, dem::Vec3(-0.06, -0.06, -0.005),
               dem::Vec3(0.06, 0.06, 0.06));
    RebuildPairList(b, grid, skin, /*near_gap=*/skin, list, threads);
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

// The sort's chunks are fixed: the threads only change who does them, so the lists are the
// same entries in the same order on any thread count.
TEST(PairList, ResortGivesTheSameListsOnAnyThreadCount) {
  dem::ParticleState b = RandomBeads(3000, 11);
  const double skin = 0.001, near_gap = 0.25 * skin;
  CellGrid grid;
  grid.Build(b.position, 0.005 + skin, dem::Vec3(-0.06, -0.06, -0.005),
             dem::Vec3(0.06, 0.06, 0.06));
  PairList one;
  RebuildPairList(b, grid, skin, near_gap, one);
  PairList four = one;
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> step(-0.2 * skin, 0.2 * skin);
  for (int round = 0; round < 3; ++round) {
    for (dem::Vec3& x : b.position) x += dem::Vec3(step(rng), step(rng), step(rng));
    const std::size_t near_before = one.partners.size();
    ResortPairList(b, near_gap, one, 1);
    ResortPairList(b, near_gap, four, 4);
    EXPECT_GT(one.partners.size(), near_before);  // some far pairs came near
    EXPECT_EQ(one.offsets, four.offsets);
    EXPECT_EQ(one.partners, four.partners);
    EXPECT_EQ(one.far_offsets, four.far_offsets);
    EXPECT_EQ(one.far_partners, four.far_partners);
  }
}

TEST(PairList, ResortTakesFarPairsThatCameNearAndKeepsTheNearHistories) {
  dem::ParticleState b = RandomBeads(1500, 9);
  const double skin = 0.001, near_gap = 0.25 * skin;
  CellGrid grid;
  grid.Build(b.position, 0.005 + skin, dem::Vec3(-0.06, -0.06, -0.005),
             dem::Vec3(0.06, 0.06, 0.06));
  PairList list;
  RebuildPairList(b, grid, skin, near_gap, list);
  for (std::uint32_t i = 0; i < b.size(); ++i)
    for (std::uint32_t k = list.offsets[i]; k < list.offsets[i + 1]; ++k)
      list.shear[k] = dem::Vec3(i, list.partners[k], 1.0);
  const PairSet stamped = NearPairs(list, b.size());
  PairSet listed = FarPairs(list, b.size());
  listed.insert(stamped.begin(), stamped.end());
  std::mt19937_64 rng(4);
  std::size_t joined = 0, apart_but_near = 0;
  PairSet near = stamped;
  for (int round = 0; round < 3; ++round) {
    // Every bead moves up to a quarter of the skin: pairs cross the near gap both ways.
    std::uniform_real_distribution<double> step(-0.25 * skin / std::sqrt(3.0),
                                                0.25 * skin / std::sqrt(3.0));
    for (dem::Vec3& x : b.position) x += dem::Vec3(step(rng), step(rng), step(rng));
    const PairSet before = near;
    ResortPairList(b, near_gap, list);
    near = NearPairs(list, b.size());
    PairSet all = FarPairs(list, b.size());
    for (const auto& pair : near) EXPECT_TRUE(all.insert(pair).second);  // in one part only
    EXPECT_EQ(all, listed);                                              // the same pairs
    for (const auto& [i, j] : listed) {
      const double near_reach = b.radius[i] + b.radius[j] + near_gap;
      const bool is_near = (b.position[i] - b.position[j]).squaredNorm() < near_reach * near_reach;
      const bool was_near = before.count({i, j}) == 1;
      // Near pairs stay near; far pairs join them when within the near gap.
      EXPECT_EQ(near.count({i, j}) == 1, was_near || is_near) << i << " " << j;
      joined += is_near && !was_near;
      apart_but_near += !is_near && was_near;
    }
    // The pairs near since the build keep their history; those that joined have none.
    for (std::uint32_t i = 0; i < b.size(); ++i)
      for (std::uint32_t k = list.offsets[i]; k < list.offsets[i + 1]; ++k) {
        const std::uint32_t j = list.partners[k];
        const dem::Vec3 expected =
            stamped.count({i, j}) == 1 ? dem::Vec3(i, j, 1.0) : dem::Vec3::Zero();
        EXPECT_EQ(list.shear[k], expected) << i << " " << j;
      }
  }
  EXPECT_GT(joined, 30u);
  EXPECT_GT(apart_but_near, 30u);
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
