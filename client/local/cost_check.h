// The CLI's side of the resource estimate (dembuf/study/run/resource_estimate.h): `--dry-run`
// prints it, and a run or sweep past this machine's limits (half its memory, the free space
// where it writes, a day of computing) stops before starting unless given `--yes`.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "dembuf/study/bed/bed.h"
#include "dembuf/study/run/resource_estimate.h"
#include "dembuf/study/scene/scene.h"
#include "dembuf/study/sweep/sweep_plan.h"

namespace dembuf::cli {

/// The hashes of the estimate's beds that are ready in `beds`.
std::vector<std::string> CachedBeds(const ResourceEstimate& estimate, BedCache& beds);

/// Checks a run (or each of `runs_at_once` runs of a sweep, `scenes`) against this machine's
/// limits for output into `out_dir`; throws ResourceError saying what passes which limit and
/// to pass --yes, unless `yes`. A bed past what a simulation can hold is refused regardless.
void CheckLocalCost(const std::vector<Scene>& scenes, const std::vector<ResourceEstimate>& costs,
                    const std::filesystem::path& out_dir, int runs_at_once, BedCache& beds,
                    bool yes);

/// The text of `dembuf run --dry-run`.
std::string DescribeRun(const ResourceEstimate& estimate, BedCache& beds, int threads);
/// The text of `dembuf sweep --dry-run`: its beds (each once, cached or not), its runs, their
/// files and memory with `jobs` runs at once.
std::string DescribeSweep(const std::vector<ResourceEstimate>& costs, BedCache& beds, int jobs,
                          int cores);
/// The schedule of a sweep's runs (schedule.h): each source bed, prepared by the run that
/// starts first with it on the threads it is given, or found in the cache; the order the runs
/// start in with their predicted start and threads; and the predicted wall time on `cores`
/// usable CPUs with at most `jobs` runs at once, times `rounds` for a search that runs the
/// same runs once a step.
std::string DescribeSweepPlan(const std::vector<SweepRun>& runs, BedCache& beds, int jobs,
                              int cores, int rounds = 1);

}  // namespace dembuf::cli
