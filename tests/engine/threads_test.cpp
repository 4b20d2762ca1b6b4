// The thread rule (dembuf/core/threads.h): never more threads than usable CPUs or than the
// beads can feed, and the CPUs counted from this process's affinity mask.
#include <gtest/gtest.h>
#include <omp.h>
#include <sched.h>

#include "dembuf/core/simulation.h"
#include "dembuf/core/threads.h"

namespace dembuf::test {
namespace {

TEST(ThreadRule, NeverMoreThreadsThanCpus) {
  EXPECT_EQ(dem::EffectiveThreads(16, 100000, 2), 2);
  EXPECT_EQ(dem::EffectiveThreads(16, 100000, 64), 16);
  EXPECT_EQ(dem::EffectiveThreads(3, 100000, 4), 3);
}

TEST(ThreadRule, NeverMoreThreadsThanTheBeadsCanFeed) {
  // A thousand beads a thread at least: the 7,910-bead impact on 7 of 16 cores.
  EXPECT_EQ(dem::EffectiveThreads(16, 7910, 16), 7);
  EXPECT_EQ(dem::EffectiveThreads(16, 30000, 16), 16);
  EXPECT_EQ(dem::EffectiveThreads(8, 999, 16), 1);
  EXPECT_EQ(dem::EffectiveThreads(8, 0, 16), 1);
}

TEST(ThreadRule, DefaultIsOpenMpsWithinTheRule) {
  const int openmp = omp_get_max_threads();
  EXPECT_EQ(dem::EffectiveThreads(0, 1000000, 1024), openmp);
  EXPECT_EQ(dem::EffectiveThreads(0, 1000000, 1), 1);
}

TEST(ThreadRule, UsableCpusAreThoseOfTheAffinityMaskAtMost) {
  cpu_set_t mask;
  ASSERT_EQ(sched_getaffinity(0, sizeof mask, &mask), 0);
  EXPECT_GE(dem::UsableCpus(), 1);
  EXPECT_LE(dem::UsableCpus(), CPU_COUNT(&mask));
}

TEST(ThreadRule, ASimulationAskedForNoCountTakesTheRulesAndOneAskedForACountTakesIt) {
  dem::WorldParams params;
  params.container = {0.05, 0.1};
  dem::ParticleState beads;
  for (int k = 0; k < 10; ++k) beads.Add(dem::Vec3(0.0, 0.0, 0.002 + 0.004 * k), 0.002, 2500.0);
  dem::Simulation sim(params, beads, std::nullopt);
  EXPECT_EQ(sim.threads(), 1);  // ten beads feed one thread
  sim.SetThreads(4);            // asked for exactly: the determinism tests need it
  EXPECT_EQ(sim.threads(), 4);
  sim.SetThreads(0);
  EXPECT_EQ(sim.threads(), 1);
}

}  // namespace
}  // namespace dembuf::test
