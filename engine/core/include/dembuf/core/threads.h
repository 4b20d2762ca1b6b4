// How many threads a simulation runs on: what was asked for (or OpenMP's default), but never
// more than the CPUs this process may use, nor more than its beads can feed. More threads than
// CPUs wait for each other at every barrier of a step (16 threads on 2 CPUs took 4.8 times as
// long as 2); more than the beads can feed spend more on the barriers than they compute
// (7,910 beads ran slower on 16 threads than on 8 of a 16-core machine). Results do not depend
// on the thread count, so the rule changes only the wall time.
#pragma once

#include <cstddef>

namespace dembuf::dem {

/// The fewest beads a thread is given. Measured on a 16-core Xeon with the impact of 7,910
/// beads: 8 threads (989 beads each) were 3.76 times as fast as one, 16 threads (494 each) only
/// 3.00 times; the 30,000-bead bed still gained up to 16 threads (1,875 each).
inline constexpr std::size_t kMinBeadsPerThread = 1000;

/// The threads `beads` beads can feed: one per kMinBeadsPerThread, at least 1.
inline int ThreadsFedBy(double beads) {
  const double fed = beads / static_cast<double>(kMinBeadsPerThread);
  return fed >= 1.0 ? static_cast<int>(fed < 1e6 ? fed : 1e6) : 1;
}

/// The CPUs this process may run on: its affinity mask (taskset, a Slurm allocation's cores),
/// and its control group's CPU quota where one is set (a container's or a Slurm job's share),
/// rounded up; never the host's count when it may use fewer. At least 1; read once.
int UsableCpus();

/// The threads for `beads` beads when `requested` are asked for (0: OpenMP's default) and
/// `cpus` CPUs are usable: at most `cpus`, at most one per kMinBeadsPerThread beads, at least 1.
int EffectiveThreads(int requested, std::size_t beads, int cpus);

}  // namespace dembuf::dem
