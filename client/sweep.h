// dembuf sweep: runs a scene over the product of varied fields (and bed seeds), in this
// process, sharing prepared beds, and reports each point's mean and spread.
#pragma once

#include <atomic>
#include <filesystem>
#include <string>
#include <vector>

#include "dembuf/study/bed.h"
#include "dembuf/study/scene.h"
#include "dembuf/study/sweep_plan.h"

namespace dembuf::cli {

struct SweepOptions {
  std::vector<SweepAxis> axes;
  int seeds = 1;  ///< bed seeds 1..seeds, unless bed.seed is varied
  int jobs = 1;   ///< runs at once
  std::filesystem::path out_dir;
  /// Raised to stop (SIGINT, SIGTERM): the runs going stop within a second, no more start,
  /// and the report of the runs done is written.
  const std::atomic<bool>* cancel = nullptr;
};

/// Runs the sweep; writes out_dir/sweep.csv, out_dir/summary.json and out_dir/runs/<job>/.
/// Returns the number of failed jobs (runs stopped by the cancel flag are not failures).
int RunSweep(const Scene& base, const SweepOptions& options, BedCache& beds);

}  // namespace dembuf::cli
