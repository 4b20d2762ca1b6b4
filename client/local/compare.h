// dembuf compare: runs and sweeps beside the paper's numbers
// (dembuf/study/sweep/paper_comparison.h).
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace dembuf::cli {

/// Reads the runs of each folder (a run's summary.json, or a sweep's runs/*/summary.json and
/// its critical thickness), prints the comparison, and writes compare.csv, compare_points.csv
/// and (with gnuplot, unless `plots` is false) compare.png into `out` (default: the first
/// folder). Returns the exit code.
int CompareCommand(const std::vector<std::filesystem::path>& folders,
                   const std::filesystem::path& out, bool plots);

}  // namespace dembuf::cli
