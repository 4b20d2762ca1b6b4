#include "block_schedule.h"

#include <thread>

namespace dembuf::detail {

void WeighBlocks(Simulation::Impl& s) {
  // Resolving a touching pair costs several times as much as checking an entry, and touching
  // pairs are not spread evenly: a bed at rest is full of them, the beads thrown up by an
  // impact have few. A touching pair costs about as much as six entries checked (a profile of
  // the impact puts it at 5 to 10).
  constexpr std::uint64_t kContactWork = 6;
  const bool listed = s.pairs.offsets.size() == s.block_start.back() + 1;
  const bool counted = s.block_contacts.size() + 1 == s.block_start.size();
  std::vector<std::uint64_t>& work = s.block_work;
  work.assign(1, 0);
  for (std::size_t k = 0; k + 1 < s.block_start.size(); ++k) {
    const std::uint32_t first = s.block_start[k], last = s.block_start[k + 1];
    const std::uint64_t entries = listed ? s.pairs.offsets[last] - s.pairs.offsets[first] : 0;
    const std::uint64_t contacts = counted ? s.block_contacts[k] : 0;
    // + 1: strictly increasing
    work.push_back(work.back() + entries + kContactWork * contacts + (last - first) + 1);
  }
}

void Pause(int& spins) {
  if (++spins < 1000) {
#if defined(__x86_64__) || defined(__i386__)
    __builtin_ia32_pause();
#endif
  } else {
    std::this_thread::yield();
  }
}

}  // namespace dembuf::detail
