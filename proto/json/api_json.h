// The API's messages as JSON: one producer of the shapes every door serves (the CLI's --json,
// the web pages' /api/..., a fetched folder's job.json; Python's package follows the same
// shapes and server.conventions compares them field by field). Names are documented in
// docs/service.md: ids and counts are numbers, states are the CLI's names ("done"), absent
// values are null, a job's summary is its summary.json object.
#pragma once

#include <cstddef>
#include <nlohmann/json.hpp>
#include <string>

#include "dembuf/v1/dembuf.pb.h"

namespace dembuf::api {

/// The largest aggregates_json taken from a server: a sweep of the daemon's most jobs
/// (max_sweep_jobs 10,000) has points of about 15 MB.
inline constexpr std::size_t kMaxAggregatesBytes = std::size_t{64} << 20;

/// "queued", "preparing_bed", "running", "done", "failed", "cancelled".
std::string StateText(v1::JobState state);

/// A job's progress: stage, fraction, sim_time_s, steps, peak_plate_force_N.
nlohmann::json ProgressJson(const v1::Progress& progress);

/// A job; `details` adds its scene, hashes, summary, result files and prepared beds. Throws
/// InputLimitError for a summary past the bounds of JSON taken from outside.
nlohmann::json JobJson(const v1::Job& job, bool details);

/// A sweep; `details` adds its aggregates (points, and Hc for a thickness sweep), which
/// GetSweep sends. Throws InputLimitError for aggregates past the bounds of JSON from outside.
nlohmann::json SweepJson(const v1::Sweep& sweep, bool details);

}  // namespace dembuf::api
