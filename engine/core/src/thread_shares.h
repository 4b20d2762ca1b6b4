// How a team of threads splits a pass over the beads when its cores are not equally fast: a
// virtual machine's cores, a core that another program also uses, big and little cores. Each
// thread's share of the work follows its measured speed, so that the threads reach the
// barrier together instead of the fast ones waiting for the slow one. Only the split changes,
// never what is computed or in which order it is summed: results stay bit-identical.
#pragma once

#include <cstddef>
#include <utility>
#include <vector>

namespace dembuf::dem::detail {

class ThreadShares {
 public:
  /// Makes room for the measurements of up to `threads` threads (before a parallel pass).
  void Prepare(int threads) {
    if (m_measured.size() < static_cast<std::size_t>(threads)) m_measured.resize(threads);
  }

  /// Where thread t's share of the work starts, as a fraction of it, in a team of `team`:
  /// 0 for t = 0 and exactly 1 for t = team. Equal shares until speeds have been measured.
  double Start(int t, int team) const {
    if (m_start.size() != static_cast<std::size_t>(team) + 1) return static_cast<double>(t) / team;
    return m_start[t];
  }

  /// Thread t's part [first, last) of `n` items split by the shares.
  std::pair<long, long> Part(long n, int t, int team) const {
    return {static_cast<long>(n * Start(t, team)), static_cast<long>(n * Start(t + 1, team))};
  }

  /// Thread t did `work` units of work in `seconds` of its own time. Each thread records only
  /// in its own slot, so the threads of a team may call this at the same time.
  void Record(int t, double work, double seconds) {
    m_measured[t].work += work;
    m_measured[t].seconds += seconds;
  }

  /// After a pass by a team of `team`: moves the shares part of the way towards the measured
  /// speeds (smoothed, since one pass's timing is noisy) and clears the measurements.
  void Update(int team);

 private:
  struct alignas(64) Measured {  // one cache line per thread: no false sharing
    double work = 0.0;
    double seconds = 0.0;
  };
  std::vector<double> m_start;  // team + 1 cumulative fractions
  std::vector<Measured> m_measured;
};

}  // namespace dembuf::dem::detail
