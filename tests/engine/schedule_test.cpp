// The schedule (dembuf/study/sweep/schedule.h): how running runs share the cores, the order a
// sweep starts its runs in, and the plan for the paper's E2 sweep on 2, 16 and 64 cores.
#include <gtest/gtest.h>

#include <algorithm>
#include <numeric>

#include "dembuf/core/threads.h"
#include "dembuf/study/scene/presets.h"
#include "dembuf/study/sweep/schedule.h"

namespace dembuf::test {
namespace {

int Sum(const std::vector<int>& threads) {
  return std::accumulate(threads.begin(), threads.end(), 0);
}

TEST(ShareCores, ARunOthersWaitForTakesWhatItsBedCanFeedFirst) {
  // A source bed of 36,805 beads that 15 runs wait for, beside a 2,000-bead run: 16 cores.
  EXPECT_EQ(ShareCores(16, {{36, 15}, {2, 0}}), (std::vector<int>{15, 1}));
  // The most waited-for first, up to what its bed feeds; the rest to the others.
  EXPECT_EQ(ShareCores(16, {{4, 0}, {6, 2}, {8, 5}}), (std::vector<int>{2, 6, 8}));
}

TEST(ShareCores, RunsOthersWaitForShareInProportionToTheWaiting) {
  // Three seeds' source beds of 36,805 beads, 16 runs waiting for each, on 16 cores: even
  // shares (Amdahl's law: each thread added gains less). Before, 14, 1 and 1.
  EXPECT_EQ(ShareCores(16, std::vector<CoreClaim>(3, {36, 16})), (std::vector<int>{6, 5, 5}));
  // One run fewer waiting moves a core, not thirteen (the most waited-for took all it could
  // feed first: 14, 1 and 1).
  EXPECT_EQ(ShareCores(16, {{36, 16}, {36, 15}, {36, 15}}), (std::vector<int>{6, 5, 5}));
  EXPECT_EQ(ShareCores(16, {{36, 15}, {36, 16}, {36, 15}}), (std::vector<int>{5, 6, 5}));
  EXPECT_EQ(ShareCores(16, {{36, 16}, {10, 20}, {36, 16}}), (std::vector<int>{5, 6, 5}));
  // Far more waiting for one bed: nearly every core to it.
  EXPECT_EQ(ShareCores(16, {{36, 30}, {36, 2}}), (std::vector<int>{15, 1}));
  EXPECT_EQ(ShareCores(16, {{36, 30}, {36, 4}}), (std::vector<int>{14, 2}));
  // What a bed cannot feed goes to the other waited-for runs first, then to the rest.
  EXPECT_EQ(ShareCores(16, {{3, 20}, {36, 1}, {36, 0}}), (std::vector<int>{3, 12, 1}));
  EXPECT_EQ(ShareCores(16, {{3, 20}, {4, 1}, {36, 0}}), (std::vector<int>{3, 4, 9}));
  for (int cores : {1, 2, 5, 16, 64})  // (a core each when more run than there are)
    EXPECT_EQ(Sum(ShareCores(cores, {{36, 7}, {36, 3}, {8, 0}})), std::max(cores, 3));
}

TEST(ShareCores, CoresNoRunCanFeedStayFree) {
  EXPECT_EQ(ShareCores(16, {{3, 0}}), (std::vector<int>{3}));
  EXPECT_EQ(ShareCores(64, {{36, 2}, {1, 0}, {2, 0}}), (std::vector<int>{36, 1, 2}));
}

TEST(ShareCores, EvenlyAmongRunsNobodyWaitsFor) {
  EXPECT_EQ(ShareCores(2, {{30, 0}}), (std::vector<int>{2}));  // alone: every core
  EXPECT_EQ(ShareCores(2, {{30, 0}, {30, 0}}), (std::vector<int>{1, 1}));
  EXPECT_EQ(ShareCores(5, {{30, 0}, {30, 0}}), (std::vector<int>{3, 2}));
  // More runs than cores (a daemon with more workers than cores): a thread each.
  EXPECT_EQ(ShareCores(2, std::vector<CoreClaim>(4, {30, 0})), (std::vector<int>(4, 1)));
  EXPECT_EQ(Sum(ShareCores(16, std::vector<CoreClaim>(5, {8, 0}))), 16);
}

TEST(ThreadsFed, AThousandBeadsAThread) {
  EXPECT_EQ(dem::ThreadsFedBy(0), 1);
  EXPECT_EQ(dem::ThreadsFedBy(999), 1);
  EXPECT_EQ(dem::ThreadsFedBy(7910), 7);
  EXPECT_EQ(dem::ThreadsFedBy(36805), 36);
  RunLoad load;  // not known: every core
  EXPECT_EQ(ThreadsMax(load, false, 16), 16);
  load = {true, "s", 36805, 100, 7910, 10};
  EXPECT_EQ(ThreadsMax(load, true, 16), 16);
  EXPECT_EQ(ThreadsMax(load, true, 64), 36);
  EXPECT_EQ(ThreadsMax(load, false, 64), 7);
}

TEST(PredictedSpeedup, AmdahlWithTheMeasuredSerialFraction) {
  EXPECT_DOUBLE_EQ(PredictedSpeedup(1), 1.0);
  // S(p) = 1 / (e + (1 - e) / p), e = 0.13: 5.4 on 16 threads (docs/performance.md).
  EXPECT_NEAR(PredictedSpeedup(16), 1.0 / (0.13 + 0.87 / 16), 1e-12);
  EXPECT_GT(PredictedSpeedup(16), 5.3);
  EXPECT_LT(PredictedSpeedup(16), 5.5);
}

// The paper's E2 sweep, 0 to 8 cm in steps of 0.5 cm, with `seeds` seeds, from an empty store.
std::vector<SweepRun> E2Sweep(int seeds) {
  const Scene e2 = PresetScene("e2");
  return ExpandSweep(
      e2, WithSeedAxis({MakeSweepAxis("bed.thickness_m", {}, "0:0.08:0.005")}, seeds, e2.bed.seed));
}

TEST(StartOrder, SourceBedsFirstThenTheHeaviestRuns) {
  const std::vector<SweepRun> runs = E2Sweep(3);
  const std::vector<RunLoad> loads = LoadsOf(runs);
  const std::vector<std::size_t> order = StartOrder(loads);
  ASSERT_EQ(order.size(), runs.size());
  // The first four runs: one of each seed's source bed (the 8 cm run, the heaviest), then a
  // bare plate, which needs no bed.
  std::vector<std::string> first;
  for (std::size_t k = 0; k < 4; ++k) first.push_back(runs[order[k]].beds.source_hash);
  std::sort(first.begin(), first.end());
  EXPECT_TRUE(first[0].empty());
  EXPECT_NE(first[1], first[2]);
  EXPECT_NE(first[2], first[3]);
  for (std::size_t k = 0; k < 4; ++k) {
    if (!runs[order[k]].beds.source_hash.empty()) {
      EXPECT_DOUBLE_EQ(runs[order[k]].scene.bed.thickness_m, 0.08);
    }
  }
  // Within a source bed, heaviest first.
  for (std::size_t a = 0; a < order.size(); ++a) {
    for (std::size_t b = a + 1; b < order.size(); ++b) {
      if (loads[order[a]].source_hash == loads[order[b]].source_hash) {
        EXPECT_GE(loads[order[a]].rest_s, loads[order[b]].rest_s);
      }
    }
  }
}

// The plan of the one-seed E2 sweep: the run preparing the source bed starts first on the
// cores its beds can feed, the bare plate beside it, every other run after the bed; never
// more threads than cores; more cores never slower.
TEST(PlanSchedule, TheE2SweepOn2And16And64Cores) {
  const std::vector<SweepRun> runs = E2Sweep(1);
  const std::vector<RunLoad> loads = LoadsOf(runs);
  const std::vector<std::size_t> order = StartOrder(loads);
  double previous_wall = 0.0;
  for (const int cores : {2, 16, 64}) {
    SCOPED_TRACE(cores);
    const SchedulePlan plan = PlanSchedule(loads, order, cores);
    ASSERT_EQ(plan.runs.size(), runs.size());
    const PlannedRun& preparer = plan.runs[0];
    EXPECT_TRUE(preparer.prepares_source);
    EXPECT_DOUBLE_EQ(runs[preparer.run].scene.bed.thickness_m, 0.08);
    // The bed feeds 36 threads; the bare plate beside it keeps one core.
    EXPECT_EQ(preparer.threads_at_start, std::min(cores - 1, 36));
    const PlannedRun& bare = plan.runs[1];
    EXPECT_TRUE(runs[bare.run].beds.source_hash.empty());
    EXPECT_EQ(bare.start_s, 0.0);
    const double bed_ready = preparer.source_ready_s;
    EXPECT_GT(bed_ready, 0.0);
    for (std::size_t k = 2; k < plan.runs.size(); ++k) {
      EXPECT_FALSE(plan.runs[k].prepares_source);
      EXPECT_GE(plan.runs[k].start_s, 0.999 * bed_ready) << runs[plan.runs[k].run].name;
      EXPECT_LE(plan.runs[k].threads_at_start, dem::ThreadsFedBy(loads[plan.runs[k].run].beads));
    }
    // On 16 cores the 16 runs cut from the bed start together as soon as it is ready.
    if (cores == 16) {
      for (std::size_t k = 2; k < plan.runs.size(); ++k) {
        EXPECT_NEAR(plan.runs[k].start_s, bed_ready, 1e-6 * bed_ready);
      }
    }
    if (previous_wall > 0) {
      EXPECT_LT(plan.wall_s, previous_wall);
    }
    previous_wall = plan.wall_s;
    EXPECT_GE(plan.wall_s, plan.one_thread_s / cores);  // no more than a core's work a core
  }
}

// Three seeds on 16 cores: the three source beds settle side by side, sharing the cores evenly.
TEST(PlanSchedule, ThreeSourceBedsSettleSideBySide) {
  const std::vector<SweepRun> runs = E2Sweep(3);
  const std::vector<RunLoad> loads = LoadsOf(runs);
  const SchedulePlan plan = PlanSchedule(loads, StartOrder(loads), 16);
  int preparing = 0, threads = 0;
  std::vector<int> source_threads;
  for (const PlannedRun& p : plan.runs)
    if (p.start_s == 0.0) {
      preparing += p.prepares_source;
      threads += p.threads_at_start;
      if (p.prepares_source) source_threads.push_back(p.threads_at_start);
    }
  EXPECT_EQ(preparing, 3);
  EXPECT_EQ(threads, 16);
  // Evenly: 5, 4 and 4 beside the three bare plates (11, 1 and 1 before).
  ASSERT_EQ(source_threads.size(), 3u);
  EXPECT_LE(*std::max_element(source_threads.begin(), source_threads.end()) -
                *std::min_element(source_threads.begin(), source_threads.end()),
            1);
  const SchedulePlan one_seed =
      PlanSchedule(LoadsOf(E2Sweep(1)), StartOrder(LoadsOf(E2Sweep(1))), 16);
  EXPECT_LT(plan.wall_s, 3.0 * one_seed.wall_s);
}

}  // namespace
}  // namespace dembuf::test
