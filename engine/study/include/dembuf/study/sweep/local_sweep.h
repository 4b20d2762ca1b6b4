// A sweep run in this process (dembuf sweep, the benchmark): a scene over the product of varied
// fields (and bed seeds), its runs taken from one RunQueue by its workers (QueueWorkers, the
// daemon's too), sharing prepared beds; each point's mean and spread reported.
#pragma once

#include <atomic>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "dembuf/study/bed/bed.h"
#include "dembuf/study/impact/impact.h"
#include "dembuf/study/scene/scene.h"
#include "dembuf/study/sweep/critical_thickness_search.h"
#include "dembuf/study/sweep/sweep_plan.h"
#include "dembuf/study/sweep/sweep_report.h"

namespace dembuf {

struct SweepOptions {
  std::vector<SweepAxis> axes;
  /// The first table_columns axes are a table's columns (TableAxes), read row by row.
  std::size_t table_columns = 0;
  bool long_table = false;  ///< also write sweep_long.csv (WriteSweepLongTable)
  int seeds = 1;            ///< bed seeds 1..seeds, unless bed.seed is varied
  int jobs = 1;             ///< runs at once
  std::filesystem::path out_dir;
  std::string command_line;  ///< what asked for the sweep, for each run's provenance
  /// Raised to stop (SIGINT, SIGTERM): the runs going stop within a second, no more start,
  /// and the report of the runs done is written.
  const std::atomic<bool>* cancel = nullptr;
  /// Called (from the run's worker) with each run's result as it ends well, e.g. for a
  /// benchmark's account of where the time went.
  std::function<void(const SweepRun&, const ImpactSummary&)> on_run_done;
  /// Called (from the preparing worker) with each bed the sweep prepared (not found).
  std::function<void(const PreparedBed&)> on_bed_prepared;
  /// Where the sweep's lines for people go (each run's end, the report's table); null: nowhere.
  std::FILE* report = stdout;
  /// Where a line on how far the sweep is goes, at most every status_interval_s; null: nowhere.
  std::FILE* status = stderr;
  double status_interval_s = 5.0;
};

/// What makes a folder's runs one sweep: the fields it varies, and the value of every other
/// field of its scene (the bed seed apart: adding seeds adds points). Derived from the field
/// table.
nlohmann::json SweepFolderKey(const Scene& base, const std::vector<std::string>& varied_fields);

/// Claims `dir` for the sweep of `key`: a new or empty folder, or one holding the same sweep
/// (resumed, points added), takes it; one holding another sweep is refused with a sentence
/// naming the fields that differ, unless `force`, which removes its runs and reports first.
/// Returns the refusal, or nothing when the folder is the sweep's.
std::optional<std::string> ClaimSweepFolder(const std::filesystem::path& dir,
                                            const nlohmann::json& key, bool force);

/// Runs the sweep; writes its folder's report (sweep_files: sweep.csv, points.csv, summary.json)
/// and out_dir/runs/<job>/. A
/// run whose scene a folder of runs/ already holds, finished, is kept (whatever its name), and
/// the report lists every run folder there is. Returns the number of failed jobs (runs stopped by
/// the cancel flag are not failures). `reports`, when given, receives every run's report.
int RunSweep(const Scene& base, const SweepOptions& options, BedCache& beds,
             std::vector<SweepRunReport>* reports = nullptr);

/// dembuf sweep --find-hc: Hc by bisection over bed.thickness_m (critical_thickness_search.h),
/// every thickness run for every seed (options.seeds, options.jobs at once) into
/// options.out_dir/runs/ as a sweep's runs; then the sweep's report over all of them, with the
/// bisection's Hc and its uncertainty in summary.json. Returns the number of failed runs
/// (a failed run stops the search).
int RunHcSearch(const Scene& base, const SweepOptions& options, const HcSearchOptions& search,
                BedCache& beds);

}  // namespace dembuf
