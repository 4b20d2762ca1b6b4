// The JSON the web pages read: jobs, sweeps with their points so far, and the batches of
// force samples of an event stream. Jobs and sweeps are the gRPC answers' messages, made by
// the same functions (api_messages.h), in the one JSON shape of api_json.h.
#pragma once

#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "jobs/executor.h"
#include "jobs/live_job.h"
#include "store/store.h"

namespace dembuf::server::web {

/// A job as api_json.h's JobJson says it at every door (of the message FillJob makes);
/// `details` adds the scene, the summary (null until done), the result files and the beds it
/// prepared.
nlohmann::json JobJson(Store& store, Executor& executor, const JobRecord& job, bool details);

/// A sweep as api_json.h's SweepJson says it with its aggregates (points so far and Hc), and
/// what the sweep's page adds: its jobs, each with its index, values and state.
nlohmann::json SweepJson(Store& store, const SweepRecord& sweep);

/// A batch of samples from index `first`, as JSON text of columns (plate_force.csv's, from
/// report::SampleColumns(); every double exact, null if not finite).
/// Written directly, not through a JSON tree: every open page encodes each sample, and this
/// is several times cheaper.
std::string SamplesJson(std::int64_t first, const std::vector<ImpactSample>& samples);

/// The state and progress of a job in an event stream.
nlohmann::json ProgressJson(JobState state, const JobProgress& progress);

}  // namespace dembuf::server::web
