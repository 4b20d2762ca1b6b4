// The gRPC service: checks every request, turns it into jobs in the store and the queue, and
// answers from the store (finished work) or the running jobs (live work).
#pragma once

#include <spdlog/logger.h>
#include <map>
#include <memory>
#include <mutex>
#include <string>

#include "access_policy.h"
#include "auth.h"
#include "dembuf/study/resource_estimate.h"
#include "dembuf/v1/dembuf.grpc.pb.h"
#include "executor.h"
#include "store.h"
#include "stream_limits.h"

namespace dembuf::server {

struct ServiceInfo {
  std::string database;
  std::string host;
  std::string started_at;
  int max_sweep_jobs = 10000;
  int quota_queued_jobs = 0;
  ResourceLimits job_limits;  ///< what one job may cost
  int max_watch_streams_per_user = 8;
  int max_watch_streams = 128;
};

class DembufService final : public v1::Dembuf::Service {
 public:
  DembufService(Store& store, Executor& executor, const AccessPolicy& policy, ServiceInfo info,
                std::shared_ptr<spdlog::logger> log);

  grpc::Status SubmitJob(grpc::ServerContext*, const v1::SubmitJobRequest*,
                         v1::SubmitJobResponse*) override;
  grpc::Status SubmitSweep(grpc::ServerContext*, const v1::SubmitSweepRequest*,
                           v1::SubmitSweepResponse*) override;
  grpc::Status GetJob(grpc::ServerContext*, const v1::GetJobRequest*, v1::Job*) override;
  grpc::Status GetSweep(grpc::ServerContext*, const v1::GetSweepRequest*, v1::Sweep*) override;
  grpc::Status ListJobs(grpc::ServerContext*, const v1::ListJobsRequest*,
                        v1::ListJobsResponse*) override;
  grpc::Status ListSweeps(grpc::ServerContext*, const v1::ListSweepsRequest*,
                          v1::ListSweepsResponse*) override;
  grpc::Status Cancel(grpc::ServerContext*, const v1::CancelRequest*, v1::CancelResponse*) override;
  grpc::Status WatchJob(grpc::ServerContext*, const v1::WatchJobRequest*,
                        grpc::ServerWriter<v1::WatchJobResponse>*) override;
  grpc::Status FetchResults(grpc::ServerContext*, const v1::FetchResultsRequest*,
                            v1::FetchResultsResponse*) override;
  grpc::Status FetchSeries(grpc::ServerContext*, const v1::FetchSeriesRequest*,
                           grpc::ServerWriter<v1::SeriesChunk>*) override;
  grpc::Status FetchFiles(grpc::ServerContext*, const v1::FetchFilesRequest*,
                          grpc::ServerWriter<v1::FileChunk>*) override;
  grpc::Status ServerInfo(grpc::ServerContext*, const v1::ServerInfoRequest*,
                          v1::ServerInfoResponse*) override;

 private:
  /// The caller, by the access policy, from the request's "authorization" metadata. Throws
  /// AccessDenied, which Guard answers.
  Caller Identify(const grpc::ServerContext* context) const;
  /// Job `id`, when it exists, the caller may see it, and it has ended (its results are
  /// there): NOT_FOUND, PERMISSION_DENIED or FAILED_PRECONDITION otherwise.
  grpc::Status FinishedJobOfCaller(grpc::ServerContext* context, std::int64_t id,
                                   std::optional<JobRecord>* job);
  /// The per-user quota of queued jobs.
  grpc::Status CheckQueuedQuota(const std::string& owner, std::size_t more);
  /// The per-job limits, against the job's resource estimate.
  grpc::Status CheckJobQuota(const Scene& scene);
  /// Runs a handler and turns any exception it lets out into a status with the reason (and
  /// a log line), instead of an abort or a reasonless answer; the access policy's refusals
  /// become UNAUTHENTICATED or PERMISSION_DENIED.
  template <class Handler>
  grpc::Status Guard(const char* rpc, Handler&& handler);
  /// For a request with a request id that `owner` used before: true, with the answer filled
  /// from the job or sweep filed then (or `status` set when it was the other kind).
  bool AnswerRetry(const std::string& owner, const std::string& request_id, bool sweep,
                   v1::SubmitJobResponse* job_answer, v1::SubmitSweepResponse* sweep_answer,
                   grpc::Status* status);
  void FillJob(const JobRecord& record, bool with_details, v1::Job* out);
  void FillSweep(const SweepRecord& record, v1::Sweep* out);

  Store& m_store;
  Executor& m_executor;
  const AccessPolicy& m_policy;
  ServiceInfo m_info;
  std::shared_ptr<spdlog::logger> m_log;
  StreamLimits m_watch_streams;
  /// Held from the look-up of a request id to the filing of its work, so that two copies of
  /// one request arriving together file it once.
  std::mutex m_submissions;
};

}  // namespace dembuf::server
