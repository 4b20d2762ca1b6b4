#include "block_schedule.h"

#include <thread>

namespace dembuf::dem::detail {

void WeighBlocks(Simulation::Impl& s) {
  // Resolving a touching pair costs several times as much as checking an entry, and touching
  // pairs are not spread evenly: a bed at rest is full of them, the beads thrown up by an
  // impact have few. A touching pair costs about as much as six entries checked (a profile of
  // the impact puts it at 5 to 10).
  constexpr std::uint64_t kContactWork = 6;
  const bool listed = s.lists.pairs.offsets.size() == s.blocks.start.back() + 1;
  const bool counted = s.blocks.contacts.size() + 1 == s.blocks.start.size();
  std::vector<std::uint64_t>& work = s.blocks.work;
  work.assign(1, 0);
  for (std::size_t k = 0; k + 1 < s.blocks.start.size(); ++k) {
    const std::uint32_t first = s.blocks.start[k], last = s.blocks.start[k + 1];
    const std::uint64_t entries =
        listed ? s.lists.pairs.offsets[last] - s.lists.pairs.offsets[first] : 0;
    const std::uint64_t contacts = counted ? s.blocks.contacts[k] : 0;
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

}  // namespace dembuf::dem::detail
