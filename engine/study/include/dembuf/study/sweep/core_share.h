// How parallel runners (the daemon's workers, a local sweep's) share the machine's cores: the
// cores of idle runners go to the running ones, so that a run the others wait for (a bed being
// prepared, the last run of a sweep) is not left on one core. The engine's results do not
// depend on its thread count, so sharing changes only the wall time.
#pragma once

#include <algorithm>

namespace dembuf {

/// Engine threads for the running runner of rank `rank` (0 .. running - 1) when `running`
/// runners share `cores` cores: an even split, the first ones taking the remainder; at least 1.
inline int CoreShare(int cores, int running, int rank) {
  if (running <= 0) return std::max(cores, 1);
  return std::max(1, cores / running + (rank < cores % running ? 1 : 0));
}

}  // namespace dembuf
