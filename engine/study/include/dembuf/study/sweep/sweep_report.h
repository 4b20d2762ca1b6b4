// The files of a sweep: sweep.csv (one row per run), points.csv (mean, sd and n of each
// metric over the runs that differ only in their bed seed; the sd is empty for one run),
// summary.json (with the critical thickness Hc for a thickness sweep), and the table printed on
// the terminal. Written the same way for a local sweep and for a sweep fetched from the daemon.
#pragma once

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "dembuf/study/sweep/sweep_plan.h"

namespace dembuf::report {

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

/// The sweep's points: the runs that differ only in their bed seed, each with the values of
/// the other axes (by field name) and, per metric of SweepMetricNames, the mean, the sample
/// standard deviation (null for one run) and n over the runs that ended well. Runs still
/// missing or failed count in no metric, so a sweep under way has points of fewer runs.
nlohmann::json SweepPoints(const std::vector<SweepAxis>& axes,
                           const std::vector<SweepRunReport>& runs);

/// Hc: the plateau is the mean P of the points in the upper half of the thickness range, and
/// a plateau only if P changes by at most 10% across that half; Hc is then the smallest
/// thickness from which every point's mean P stays within 10% of the plateau. Where P has not
/// levelled off, Hc_m is null, `reached` false and `note` says how much P still changes.
/// Null for fewer than three thicknesses. `h_to_p` is sorted by thickness.
nlohmann::json CriticalThickness(const std::vector<std::pair<double, double>>& h_to_p);

/// Writes dir/sweep.csv, dir/points.csv and dir/summary.json (the returned document, with
/// `extra` merged in) and prints the table of points to `table`. A thickness sweep gets Hc by
/// CriticalThickness unless `extra` brings its own "critical_thickness".
nlohmann::json WriteSweepReport(const std::filesystem::path& dir,
                                const std::vector<SweepAxis>& axes,
                                const std::vector<SweepRunReport>& runs,
                                const nlohmann::json& extra, std::FILE* table);

}  // namespace dembuf::report
