// Which thread resolves which blocks of beads in the force pass, in which order, and who waits
// for whom. Blocks are layers of cells (ForcePassBlocks::start); a pair joins beads of
// one layer or of two neighbouring ones, and "of two neighbouring layers, the even one first"
// fixes the order of every bead's sum. Each thread sweeps its consecutive blocks once in that
// order (0, 2, 1, 4, 3, ...: a bead's data is still in cache when its forces are complete); an
// odd block at the edge of a share waits for its even neighbour in the next share, which the
// thread holding it does first. Nothing here decides what is summed, only when.
#pragma once

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <vector>

#include "simulation_state.h"

namespace dembuf::dem::detail {

/// Weighs the blocks (ForcePassBlocks::work): a block's list entries and beads, and its touching
/// pairs once a pass has counted them. Only the split between threads depends on it.
void WeighBlocks(Simulation::Impl& s);

/// Waits a moment for another thread (a short spin, then giving the core away: the other
/// thread may be waiting for this core when teams are nested or cores are shared).
void Pause(int& spins);

/// Where a thread's run of consecutive items starts when each thread takes about its share of
/// their work: `cumulative` holds the work before each item and the total last, `fraction` is
/// where the thread's share starts (ThreadShares::Start). 0 gives the first item, 1 one past
/// the last.
template <class Work>
long ShareStart(const std::vector<Work>& cumulative, double fraction) {
  const long items = static_cast<long>(cumulative.size()) - 1;
  if (fraction >= 1.0) return items;
  const double target = static_cast<double>(cumulative.back()) * fraction;
  return std::lower_bound(cumulative.begin(), cumulative.end() - 1, target) - cumulative.begin();
}

/// Calls resolve(k) for this thread's blocks [first, last) of `blocks`, in the sweep order,
/// marking each done in this `pass`; an odd block first waits for its even neighbours that
/// other threads hold.
template <class Resolve>
void SweepBlocks(long first, long last, long blocks, std::atomic<std::uint64_t>* done,
                 std::uint64_t pass, Resolve&& resolve) {
  auto run = [&](long k) {
    if (k % 2 == 1)  // odd: after its even neighbours, which may be another thread's
      for (const long even : {k - 1, k + 1})
        if (even >= 0 && even < blocks && (even < first || even >= last))
          for (int spins = 0; done[even].load(std::memory_order_acquire) != pass;) Pause(spins);
    resolve(k);
    done[k].store(pass, std::memory_order_release);
  };
  // An even last block first: the next share's first block may be waiting for it.
  const bool last_first = last > first && (last - 1) % 2 == 0;
  if (last_first) run(last - 1);
  for (long even = first + first % 2; even - 1 < last; even += 2) {
    if (even < last && !(last_first && even == last - 1)) run(even);
    if (even - 1 >= first) run(even - 1);
  }
}

}  // namespace dembuf::dem::detail
