// dembuf sweep: runs a scene over the product of varied fields (and bed seeds), in this
// process, sharing prepared beds, and reports each point's mean and spread.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "dembuf/engine/bed.h"
#include "dembuf/engine/scene.h"

namespace dembuf::cli {

/// One varied field and its values (as text, applied with SetSceneField).
struct SweepAxis {
  std::string field;
  std::vector<std::string> values;
};

/// Parses "dotted.field=START:STOP:STEP" (inclusive) or "dotted.field=v1,v2,...". Throws
/// SceneError naming the field.
SweepAxis ParseVary(const std::string& spec);

struct SweepOptions {
  std::vector<SweepAxis> axes;
  int seeds = 1;  ///< bed seeds 1..seeds, unless bed.seed is varied
  int jobs = 1;   ///< runs at once
  std::filesystem::path out_dir;
};

/// Runs the sweep; writes out_dir/sweep.csv, out_dir/summary.json and out_dir/runs/<job>/.
/// Returns the number of failed jobs.
int RunSweep(const Scene& base, const SweepOptions& options, BedCache& beds);

}  // namespace dembuf::cli
