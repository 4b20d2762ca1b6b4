// A sweep's aggregates and files. The aggregates (the points over the bed seeds and, for a
// thickness sweep, Hc) are computed here once and served as they are by every door: the
// folder's points.csv and summary.json, the daemon's GetSweep and /api/sweeps/ID, the CLI's
// --json and Python. The files: sweep.csv (one row per run), points.csv (one row per point),
// summary.json and the table printed on the terminal, written the same way for a local sweep
// and for a sweep fetched from the daemon.
#pragma once

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "dembuf/study/sweep/sweep_plan.h"

namespace dembuf {

/// A sweep folder's files besides its runs' folders (runs/NAME, run folders), named here only.
namespace sweep_files {
inline constexpr const char* kRuns = "runs";
inline constexpr const char* kTable = "sweep.csv";    ///< a row per run
inline constexpr const char* kPoints = "points.csv";  ///< a row per point: mean and spread
/// Every sample of every run, one table (WriteSweepLongTable: sweep --long, fetch --long).
inline constexpr const char* kLong = "sweep_long.csv";
inline constexpr const char* kSummary = "summary.json";
inline constexpr const char* kIncomplete = "incomplete.json";  ///< a sweep interrupted
/// What makes the folder's runs one sweep (SweepFolderKey, local_sweep.h).
inline constexpr const char* kKey = "sweep_scene.json";
}  // namespace sweep_files

/// One run of the sweep and how it ended.
struct SweepRunReport {
  std::string name;                 ///< folder name, e.g. "003_thickness_m=0.01_seed=2"
  std::vector<std::string> values;  ///< one per axis
  bool ok = false;
  std::string error;
  nlohmann::json summary;  ///< summary.json of the run, when ok
  std::int64_t id = 0;     ///< the daemon's job id (0: a local run)
  std::string state;       ///< the job's state when not ended well ("" : done or failed by ok)
};

/// A swept value as JSON gives it at every door: a whole number, a number, else its text
/// (bed.seed 2, bed.thickness_m 0.01, bed.cut "tops"), as a CSV reader types sweep.csv's.
nlohmann::json SweepValueJson(const std::string& text);
nlohmann::json SweepValuesJson(const std::vector<std::string>& texts);

/// A run's status as sweep.csv and Client.sweep() give it: a job state's name ("done",
/// "failed", "cancelled", "queued", "running").
std::string RunStatus(const SweepRunReport& run);

/// The summary fields a sweep tabulates, in column order.
const std::vector<std::string>& SweepMetricNames();

/// The columns of a sweep point, in order: the swept fields but bed.seed, `runs`, then per
/// metric M of SweepMetricNames `M` (the mean), `M_sd` and `M_n`. points.csv's header.
std::vector<std::string> SweepPointColumns(const std::vector<SweepAxis>& axes);

/// The sweep's points: the runs that differ only in their bed seed, each one flat object of
/// SweepPointColumns: the values of the other axes, the number of runs, and per metric the
/// mean, the sample standard deviation (null for one run) and n over the runs that ended well
/// (mean null and n 0 where none has it). Runs still missing or failed count in no metric, so
/// a sweep under way has points of fewer runs. Points are in the order of their values,
/// numbers by value (2, 5, 10), text by its characters.
nlohmann::json SweepPoints(const std::vector<SweepAxis>& axes,
                           const std::vector<SweepRunReport>& runs);

/// {"points": SweepPoints, "point_columns": SweepPointColumns (their order)} and, for a sweep
/// over bed.thickness_m alone (seeds aside) with three thicknesses or more that have a P,
/// "Hc_m" and "critical_thickness" (CriticalThickness of the points' mean P).
nlohmann::json SweepAggregates(const std::vector<SweepAxis>& axes,
                               const std::vector<SweepRunReport>& runs);

/// Hc: the plateau is the mean P of the points in the upper half of the thickness range, and
/// a plateau only if P changes by at most 10% across that half; Hc is then the smallest
/// thickness from which every point's mean P stays within 10% of the plateau. Where P has not
/// levelled off, Hc_m is null, `reached` false and `note` says how much P still changes.
/// Null for fewer than three thicknesses. `h_to_p` is sorted by thickness.
nlohmann::json CriticalThickness(const std::vector<std::pair<double, double>>& h_to_p);

/// Writes dir/sweep.csv, dir/points.csv and dir/summary.json (the returned document, with
/// `extra` merged in) and prints the table of points to `table` (null: nowhere). The points and Hc
/// are SweepAggregates'; a "critical_thickness" in `extra` (--find-hc's) replaces its Hc.
nlohmann::json WriteSweepReport(const std::filesystem::path& dir,
                                const std::vector<SweepAxis>& axes,
                                const std::vector<SweepRunReport>& runs,
                                const nlohmann::json& extra, std::FILE* table);

/// Writes dir/sweep_long.csv, the sweep's series as one tidy table for pandas or R: a row per
/// sample of every run that ended well, its columns the run's number (sweep.csv's `run`), the
/// swept fields, then plate_force.csv's columns (t_s, plate_force_N, ...). Reads each run's
/// dir/runs/NAME/plate_force.csv a line at a time; returns the rows written. Throws
/// std::runtime_error for a series it cannot read or whose columns differ from the first's.
std::size_t WriteSweepLongTable(const std::filesystem::path& dir,
                                const std::vector<SweepAxis>& axes,
                                const std::vector<SweepRunReport>& runs);

}  // namespace dembuf
