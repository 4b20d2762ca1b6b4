// The JSON the web pages read: jobs, sweeps with their points so far, the server, and the
// batches of force samples of an event stream. Made from the same store records and live
// progress as the gRPC answers (no second source of truth); pure functions of them.
#pragma once

#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "executor.h"
#include "live_job.h"
#include "store.h"

namespace dembuf::server::web {

/// A job as the list shows it: identity, state, progress, times, and the peak plate force
/// (the running job's so far, else its summary's; null when neither exists).
nlohmann::json JobJson(const JobRecord& job, const JobProgress& progress,
                       const std::string& summary_json);

/// JobJson with what the job's page adds: the scene, the summary as an object (null until
/// done), the result files and the beds it prepared.
nlohmann::json JobDetailsJson(const JobRecord& job, const JobProgress& progress,
                              const std::string& summary_json,
                              const std::vector<JobFileInfo>& files,
                              const std::vector<std::string>& beds_prepared);

/// A sweep: its axes (with units), jobs by state, and its points so far (mean, sd and n over
/// the seeds of every metric, from the jobs that are done).
nlohmann::json SweepJson(const SweepRecord& sweep, const std::vector<SweepJobResult>& jobs);

/// A batch of samples from index `first`, as JSON text of columns (`t_s`, `plate_force_N`,
/// `wall_force_z_N`, `proj_z_m`, `proj_force_z_N`; every double exact, null if not finite).
/// Written directly, not through a JSON tree: every open page encodes each sample, and this
/// is several times cheaper.
std::string SamplesJson(std::int64_t first, const std::vector<ImpactSample>& samples);

/// The state and progress of a job in an event stream.
nlohmann::json ProgressJson(JobState state, const JobProgress& progress);

/// A summary.json text as an object; null for "" or text that is not JSON.
nlohmann::json ParseSummary(const std::string& summary_json);

}  // namespace dembuf::server::web
