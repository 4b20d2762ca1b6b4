// The gRPC service: checks every request, turns it into jobs in the store and the queue, and
// answers from the store (finished work) or the running jobs (live work).
#pragma once

#include <spdlog/logger.h>
#include <chrono>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>

#include "access/access_policy.h"
#include "access/auth.h"
#include "dembuf/study/run/resource_estimate.h"
#include "dembuf/v1/dembuf.grpc.pb.h"
#include "doors/call_pool.h"
#include "doors/stream_clock.h"
#include "doors/stream_limits.h"
#include "jobs/executor.h"
#include "store/store.h"

namespace dembuf::server {

/// What the service says of itself and the limits it applies, as MakeServiceInfo takes them
/// from the daemon's configuration (whose defaults are in config.h, and nowhere else).
struct ServiceInfo {
  std::string database;
  std::string host;
  std::string started_at;
  int max_sweep_jobs = 0;
  int quota_queued_jobs = 0;            ///< per user; 0: none
  std::int64_t quota_stored_bytes = 0;  ///< per user; 0: none
  ResourceLimits job_limits;            ///< what one job may cost
  int max_watch_streams_per_user = 0;
  int max_watch_streams = 0;
  int max_fetch_streams_per_user = 0;
  int max_fetch_streams = 0;
  std::chrono::seconds stream_write_timeout{};
  std::int64_t max_bed_push_bytes = 0;
  bool notify = false;  ///< a chat hook tells owners of their work's end (notify_url_file)
};

/// Pushes of beds at once, per user and in all: each holds its bed in memory until it is
/// checked (max_bed_push_mb).
inline constexpr int kMaxBedPushesPerUser = 1;
inline constexpr int kMaxBedPushes = 4;
/// A user's stored bed files hold at most this many pushes' worth (4 x max_bed_push_mb); the
/// oldest no unfinished job imports make way for new ones.
inline constexpr int kBedFileRoomPerPush = 4;

/// Every call of the dembuf API is served on gRPC's callback API. A unary call is identified
/// on gRPC's thread (from memory: AccessPolicy) and its work done by the CallPool, users in
/// turn; a stream (StreamReactor, BedPushReactor) holds no thread while it waits.
using DembufServiceBase = v1::Dembuf::CallbackService;

/// The CallPool's threads, and the calls of one user that may run on them and wait for them
/// at once.
inline constexpr int kCallThreads = 8;
inline constexpr std::size_t kCallsRunningPerUser = 2;
inline constexpr std::size_t kCallsWaitingPerUser = 64;

class DembufService final : public DembufServiceBase {
 public:
  DembufService(Store& store, Executor& executor, const AccessPolicy& policy, ServiceInfo info,
                std::shared_ptr<spdlog::logger> log);

  grpc::ServerUnaryReactor* SubmitJob(grpc::CallbackServerContext*, const v1::SubmitJobRequest*,
                                      v1::SubmitJobResponse*) override;
  grpc::ServerUnaryReactor* SubmitSweep(grpc::CallbackServerContext*, const v1::SubmitSweepRequest*,
                                        v1::SubmitSweepResponse*) override;
  grpc::ServerUnaryReactor* GetJob(grpc::CallbackServerContext*, const v1::GetJobRequest*,
                                   v1::Job*) override;
  grpc::ServerUnaryReactor* GetSweep(grpc::CallbackServerContext*, const v1::GetSweepRequest*,
                                     v1::Sweep*) override;
  grpc::ServerUnaryReactor* ListJobs(grpc::CallbackServerContext*, const v1::ListJobsRequest*,
                                     v1::ListJobsResponse*) override;
  grpc::ServerUnaryReactor* ListSweeps(grpc::CallbackServerContext*, const v1::ListSweepsRequest*,
                                       v1::ListSweepsResponse*) override;
  grpc::ServerUnaryReactor* Cancel(grpc::CallbackServerContext*, const v1::CancelRequest*,
                                   v1::CancelResponse*) override;
  grpc::ServerUnaryReactor* Delete(grpc::CallbackServerContext*, const v1::DeleteRequest*,
                                   v1::DeleteResponse*) override;
  grpc::ServerWriteReactor<v1::WatchJobResponse>* WatchJob(grpc::CallbackServerContext*,
                                                           const v1::WatchJobRequest*) override;
  grpc::ServerUnaryReactor* FetchResults(grpc::CallbackServerContext*,
                                         const v1::FetchResultsRequest*,
                                         v1::FetchResultsResponse*) override;
  grpc::ServerWriteReactor<v1::SeriesChunk>* FetchSeries(grpc::CallbackServerContext*,
                                                         const v1::FetchSeriesRequest*) override;
  grpc::ServerWriteReactor<v1::FileChunk>* FetchFiles(grpc::CallbackServerContext*,
                                                      const v1::FetchFilesRequest*) override;
  grpc::ServerUnaryReactor* ServerInfo(grpc::CallbackServerContext*, const v1::ServerInfoRequest*,
                                       v1::ServerInfoResponse*) override;
  grpc::ServerReadReactor<v1::BedPiece>* PushBed(grpc::CallbackServerContext*,
                                                 v1::PushBedResponse*) override;

 private:
  /// The caller, by the access policy, from the request's "authorization" metadata. Throws
  /// AccessDenied, which Guard answers.
  Caller Identify(const grpc::ServerContextBase* context) const;
  /// A unary call: its caller identified here, on gRPC's thread, and `work(caller)` queued
  /// on the CallPool under the caller's name; its status answers the call (Guard's).
  template <class Work>
  grpc::ServerUnaryReactor* Serve(const char* rpc, grpc::CallbackServerContext* context, Work work);
  /// Job `id`, when it exists, the caller may see it, and it has ended (its results are
  /// there): NOT_FOUND, PERMISSION_DENIED or FAILED_PRECONDITION otherwise.
  grpc::Status FinishedJobOfCaller(const Caller& caller, std::int64_t id,
                                   std::optional<JobRecord>* job);
  /// For a result stream: the caller's finished job `id` and a place under the fetch caps.
  grpc::Status OpenFetchStream(const char* rpc, const grpc::ServerContextBase* context,
                               std::int64_t id, Caller* caller, std::optional<JobRecord>* job,
                               std::optional<StreamLimits::Place>* place);
  /// The jobs a Cancel or Delete names: job `job_id`, or those of sweep `sweep_id` (exactly
  /// one given), when they exist and the caller may do `action` to them.
  grpc::Status TargetedJobs(const Caller& caller, Action action, std::int64_t job_id,
                            std::int64_t sweep_id, std::vector<JobRecord>* targets);
  /// The refusal of a call when the caller has the most calls waiting a user may have.
  grpc::Status CallsWaiting(const Caller& caller) const;
  /// The per-user quotas: queued jobs, and stored results (`more_bytes` the new jobs' bound).
  grpc::Status CheckQueuedQuota(const std::string& owner, std::size_t more);
  /// A submission with `notify` refused while its owner is owed kMaxWaitingNotificationsPerUser.
  grpc::Status CheckNotifyRoom(bool notify, const std::string& owner);
  /// A done job whose result `job` may take instead of running (0: none): of the same scene
  /// (seed included) and bed file, made by this very engine (version, commit, build type and
  /// configuration, from its summary's provenance), one the job's owner may read (as `caller`
  /// files it: AccessPolicy::FiledAs), and whose summary, series and files match their
  /// checksums (a damaged one is logged and passed over).
  std::int64_t ReusableResult(const Caller& caller, const JobRecord& job);
  grpc::Status CheckStoredQuota(const std::string& owner, double more_bytes);
  /// Runs a handler and turns any exception it lets out into a status with the reason (and
  /// a log line), instead of an abort or a reasonless answer; the access policy's refusals
  /// become UNAUTHENTICATED or PERMISSION_DENIED.
  template <class Handler>
  grpc::Status Guard(const char* rpc, Handler&& handler);
  /// The status for the exception being handled (inside a catch): what Guard answers.
  grpc::Status FailureStatus(const char* rpc);
  /// For a request with a request id that `owner` used before: true, with the answer filled
  /// from the job or sweep filed then (or `status` set when it was the other kind).
  bool AnswerRetry(const std::string& owner, const std::string& request_id, bool sweep,
                   v1::SubmitJobResponse* job_answer, v1::SubmitSweepResponse* sweep_answer,
                   grpc::Status* status);
  /// What a submission files once admitted: its jobs, the bytes their results may store at
  /// most, the scenes' warnings, and how the store keeps them (a job alone, a sweep's jobs).
  struct Filing {
    std::vector<JobRecord> jobs;
    double output_bytes = 0.0;
    std::vector<std::string> warnings;
    std::function<void(std::vector<JobRecord>& jobs)> store;
    bool reuse = true;                ///< answer jobs from stored results where they match
    std::function<bool()> cancelled;  ///< whether the caller has left (the lookup stops)
  };
  /// The one path of SubmitJob and SubmitSweep, once the request's labels are checked. A retry
  /// (the owner's request id filed before: answered into `job_answer` or `sweep_answer`, the
  /// one of the request's kind) is looked for before the admission and again as the jobs are
  /// filed, so that two copies admitted at once file them once; `admit` makes the Filing (its
  /// SceneError, ResourceError and Cancelled answered here); then the stored quota, the stored
  /// results its jobs may take (ReusableResult) and, under m_submissions, the caller's token,
  /// the quotas, the executor's room and the store (FileAdmitted). Returns the answer's status
  /// and, in `filed`, what was filed (no jobs: a retry was answered).
  grpc::Status FileSubmission(const Caller& caller, const std::string& owner,
                              const std::string& request_id, v1::SubmitJobResponse* job_answer,
                              v1::SubmitSweepResponse* sweep_answer,
                              const std::function<Filing()>& admit, Filing& filed);
  /// Files an admitted submission, under m_submissions: the queued-jobs quota, the executor's
  /// room and the store. A result to reuse that was deleted meanwhile makes its jobs ones to
  /// run, counted again (FileSubmission's last step).
  grpc::Status FileAdmitted(const std::string& owner, Filing& filing);
  /// The caller's bed file a scene spec names (SceneSpec.bed_file), or none when it names
  /// none. Throws SceneError naming bed_file when the owner sent no such file.
  std::optional<BedFile> BedFileOf(const v1::SceneSpec& spec, const std::string& owner);
  /// A whole pushed bed: checked, then kept (PushBed).
  grpc::Status ReceiveBed(const Caller& caller, const v1::BedPiece& first, std::string data,
                          v1::PushBedResponse* response);

  Store& m_store;
  Executor& m_executor;
  const AccessPolicy& m_policy;
  ServiceInfo m_info;
  std::shared_ptr<spdlog::logger> m_log;
  StreamLimits m_watch_streams;
  StreamLimits m_fetch_streams;
  StreamLimits m_bed_pushes;
  StreamClock m_clock;  ///< the streams' timed work
  /// Held from the look-up of a request id to the filing of its work, so that two copies of
  /// one request arriving together file it once.
  std::mutex m_submissions;
  CallPool m_calls;  ///< last: its workers end (answering what waits) before the rest goes
};

}  // namespace dembuf::server
