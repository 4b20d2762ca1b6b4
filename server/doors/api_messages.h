// The store's records as the API's messages: one conversion for the gRPC service and the web
// pages' JSON API (which serves api_json.h's JSON of these messages), so that both doors say
// the same about a job or a sweep.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "dembuf/v1/dembuf.pb.h"
#include "jobs/executor.h"
#include "store/store.h"

namespace dembuf::server {

/// The most a listing's answer (ListJobs, ListSweeps, the web API's lists) may hold: a longer
/// one is refused, naming `limit`, before it is built (the clients take answers up to 128 MiB).
inline constexpr std::int64_t kMaxListAnswerBytes = std::int64_t{64} << 20;

/// A job state in the API and back (nullopt for UNSPECIFIED or a state not known).
v1::JobState ToProto(JobState state);
std::optional<JobState> FromProto(v1::JobState state);
void FillProgress(const JobProgress& progress, v1::Progress* out);

/// The job's message: its record, its progress (the running job's own, else its stored state's)
/// and, with details, its scene, result files, prepared beds and summary. A damaged summary is
/// left out and named as the job's error, or, with `damaged_summary_fails` (a fetch), thrown
/// (DamagedData).
void FillJob(Store& store, Executor& executor, const JobRecord& record, bool with_details,
             v1::Job* out, bool damaged_summary_fails = false);

/// The sweep's message; `with_aggregates` adds SweepAggregatesJson of its jobs.
void FillSweep(Store& store, const SweepRecord& record, bool with_aggregates, v1::Sweep* out);

/// The newest `limit` sweeps of `owner` ("" for everyone's) into `out`, without aggregates;
/// false, with no more added, once they would pass kMaxListAnswerBytes.
bool FillSweepList(Store& store, const std::string& owner, int limit,
                   google::protobuf::RepeatedPtrField<v1::Sweep>* out);

/// The sweep's points and Hc (the study layer's SweepAggregates) over all its jobs, only those
/// done counting in a metric (a job whose summary is damaged in none), as JSON text.
std::string SweepAggregatesJson(const SweepRecord& record, const std::vector<SweepJobResult>& jobs);

}  // namespace dembuf::server
