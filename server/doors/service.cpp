#include "doors/service.h"

#include <algorithm>
#include <cctype>
#include <chrono>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <thread>

#include "access/auth.h"
#include "dembuf/study/bed/bed.h"
#include "dembuf/study/files/provenance.h"
#include "dembuf/study/impact/impact.h"
#include "dembuf/study/scene/errors.h"
#include "dembuf/study/scene/scene_fields.h"
#include "dembuf/study/sweep/schedule.h"
#include "dembuf/study/sweep/sweep_plan.h"
#include "dembuf/study/text/content_hash.h"
#include "dembuf/study/text/text_limits.h"
#include "dembuf/study/version.h"
#include "doors/admission.h"
#include "doors/api_messages.h"
#include "doors/bed_push.h"
#include "doors/scene_request.h"
#include "doors/stream_reactor.h"
#include "jobs/job_feed.h"

namespace dembuf::server {

namespace {

using grpc::Status;
using grpc::StatusCode;

constexpr std::size_t kSamplesPerMessage = 512;
// FetchResults answers with a series of at most this many samples (3 MB); FetchSeries streams
// longer ones.
constexpr std::int64_t kMaxSamplesInResults = 65536;

Status Invalid(const std::string& field, const std::string& message) {
  return Status(StatusCode::INVALID_ARGUMENT, field.empty() ? message : field + ": " + message);
}

Status FromSceneError(const SceneError& e) {
  return Status(StatusCode::INVALID_ARGUMENT, e.what());
}

// A job past the server's limits: the details name the field, so that the client knows the
// request must change (it is not worth retrying).
Status OverLimits(const ResourceError& e) {
  return Status(StatusCode::RESOURCE_EXHAUSTED, e.what(), "field=" + e.field());
}

std::string Megabytes(double bytes) {
  char text[32];
  std::snprintf(text, sizeof text, "%.4g MB", bytes / 1e6);
  return text;
}

// A stream's caller whose token was revoked or replaced while it streamed.
Status TokenWithdrawn() {
  return Status(StatusCode::UNAUTHENTICATED,
                "token: revoked or replaced since the stream began; it is closed");
}

Status DiskFull() {
  return Status(StatusCode::RESOURCE_EXHAUSTED,
                "the server's disk is full; nothing was changed (the administrator must free "
                "space)");
}

// A listing past kMaxListAnswerBytes, refused rather than built.
Status ListTooLarge(int limit, const char* what) {
  return Status(StatusCode::RESOURCE_EXHAUSTED,
                "limit: the " + std::to_string(limit) + " newest " + what +
                    " would make an answer of more than " +
                    std::to_string(kMaxListAnswerBytes >> 20) + " MiB; ask for fewer (limit)",
                "field=limit");
}

void FillSample(const ImpactSample& s, v1::ForceSample* out) {
  out->set_t_s(s.t_s);
  out->set_plate_force_n(s.plate_force_N);
  out->set_wall_force_z_n(s.wall_force_z_N);
  out->set_proj_z_m(s.projectile_z_m);
  out->set_proj_vz_m_s(s.projectile_vz_m_s);
  out->set_proj_force_z_n(s.projectile_force_z_N);
}

// Names and command lines end up in logs, tables and terminals: bounded, and text that shows
// as what it is (no control characters, no bidirectional reordering, UTF-8).
Status CheckLabel(const std::string& field, const std::string& value, std::size_t max_length) {
  if (value.size() > max_length)
    return Invalid(field, "longer than " + std::to_string(max_length) + " characters");
  if (const std::string problem = DisplayTextProblem(value); !problem.empty())
    return Invalid(field, problem);
  return Status::OK;
}

// A client's request id: "" (none) or 1 to 64 of [A-Za-z0-9._-].
Status CheckRequestId(const std::string& id) {
  if (id.empty()) return Status::OK;
  const bool plain =
      id.size() <= 64 && std::all_of(id.begin(), id.end(), [](char c) {
        return std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '_' || c == '-';
      });
  return plain ? Status::OK
               : Invalid("request_id",
                         "must be 1 to 64 letters, digits, '.', '_' or '-' (a "
                         "UUID), or empty");
}

// "" means: not given.
Status CheckOwner(const std::string& owner) {
  if (owner.empty()) return Status::OK;
  const std::string problem = UserNameProblem(owner);
  return problem.empty() ? Status::OK : Invalid("owner", problem);
}

// What every submission (a job, a sweep) passes first: whose name it is filed under (set in
// `owner`), its name, the command line kept with it and its request id.
template <class Request>
Status CheckSubmission(const Caller& caller, const Request& request, bool can_notify,
                       std::string* owner) {
  if (Status s = CheckOwner(request.owner()); !s.ok()) return s;
  if (request.notify() && !can_notify)
    return Status(StatusCode::INVALID_ARGUMENT,
                  "notify: this daemon has no chat hook to tell you through (its administrator "
                  "sets notify_url_file); dembuf watch --sweep ID waits for a sweep's end");
  *owner = AccessPolicy::OwnerFor(caller, request.owner());
  if (Status s = CheckLabel("name", request.name(), 200); !s.ok()) return s;
  if (Status s = CheckLabel("command_line", request.command_line(), kMaxCommandLineBytes); !s.ok())
    return s;
  return CheckRequestId(request.request_id());
}

std::optional<std::string> AuthorizationOf(const grpc::ServerContextBase* context) {
  const auto& metadata = context->client_metadata();
  const auto found = metadata.find("authorization");
  if (found == metadata.end()) return std::nullopt;
  return std::string(found->second.data(), found->second.size());
}

/// What is kept of a client's command line: without the caller's token, wherever it stands,
/// and without the value of any --token option (a job's command line is shown to whoever may
/// read the job, and written into its summary).
std::string KeptCommandLine(const grpc::ServerContextBase* context, const std::string& line) {
  std::string token;
  if (const std::optional<std::string> authorization = AuthorizationOf(context))
    token = authorization->substr(std::min(authorization->size(), std::string("Bearer ").size()));
  return report::WithoutSecrets(line, token);
}

// A job that was to reuse a result, to be filed to run instead.
JobRecord Unreused(JobRecord job) {
  job.reused_from = 0;
  job.state = JobState::kQueued;
  job.id = 0;
  return job;
}

JobRecord MakeJobRecord(const Scene& scene, const std::string& owner, const std::string& name) {
  JobRecord job;
  job.owner = owner.empty() ? "anonymous" : owner;
  job.name = name;
  job.scene_toml = report::SceneText(scene);
  job.scene_hash = ContentHash(job.scene_toml);
  const BedNeeds beds = BedNeedsOf(scene);
  job.bed_hash = beds.bed_hash;
  job.source_hash = beds.source_hash;
  return job;
}

}  // namespace

Caller DembufService::Identify(const grpc::ServerContextBase* context) const {
  return m_policy.Identify(AuthorizationOf(context));
}

Status DembufService::CheckQueuedQuota(const std::string& owner, std::size_t more) {
  if (m_info.quota_queued_jobs <= 0) return Status::OK;
  const int queued = m_store.CountQueuedBy(owner);
  if (queued + static_cast<long>(more) <= m_info.quota_queued_jobs) return Status::OK;
  // The details name the quota: not worth retrying before the queue moves.
  return Status(StatusCode::RESOURCE_EXHAUSTED,
                "owner: " + owner + " has " + std::to_string(queued) + " jobs queued; " +
                    std::to_string(more) + " more would pass the quota of " +
                    std::to_string(m_info.quota_queued_jobs) +
                    " per user (quota_queued_jobs): wait for them to run, or cancel some",
                "quota=quota_queued_jobs");
}

Status DembufService::CheckNotifyRoom(bool notify, const std::string& owner) {
  if (!notify) return Status::OK;
  const int waiting = m_store.CountWaitingNotifications(owner);
  if (waiting < kMaxWaitingNotificationsPerUser) return Status::OK;
  return Status(StatusCode::RESOURCE_EXHAUSTED,
                "notify: " + owner + " has " + std::to_string(waiting) +
                    " notifications waiting or filed in the last hour, the most one user may (" +
                    std::to_string(kMaxWaitingNotificationsPerUser) +
                    "): a sweep is told of once, however many its jobs",
                "quota=notifications");
}

std::int64_t DembufService::ReusableResult(const Caller& caller, const JobRecord& job) {
  // As the job's owner may read: an admin filing for bob reuses only what bob may read.
  const Caller owner = m_policy.FiledAs(caller, job.owner);
  const std::optional<std::string> only_of =
      owner.admin ? std::nullopt : std::optional<std::string>(owner.name);
  for (const JobRecord& done :
       m_store.DoneJobsOfScene(job.scene_hash, job.scene_toml, job.bed_file, only_of)) {
    if (!AccessPolicy::Allows(owner, Action::kRead, done.owner)) continue;
    try {
      if (!report::MadeByThisEngine(nlohmann::json::parse(m_store.Summary(done.id), nullptr, false),
                                    report::BuildMatch::kIdentifiedBuild))
        continue;
      m_store.GetResults(done.id);  // (the whole series, checked against its checksums)
      for (const JobFileInfo& file : m_store.JobFiles(done.id))
        m_store.ReadJobFile(done.id, file.path, 0, 1);  // (a read from 0 checks the file)
      return done.id;
    } catch (const StoreError& e) {
      m_log->warn("job {}'s result is not reused: {}", done.id, e.what());
    }
  }
  return 0;
}

Status DembufService::CheckStoredQuota(const std::string& owner, double more_bytes) {
  if (m_info.quota_stored_bytes <= 0) return Status::OK;
  const std::int64_t stored = m_store.StoredBytesOf(owner);
  if (static_cast<double>(stored) + more_bytes <= static_cast<double>(m_info.quota_stored_bytes))
    return Status::OK;
  return Status(StatusCode::RESOURCE_EXHAUSTED,
                "owner: " + owner + " stores " + Megabytes(static_cast<double>(stored)) +
                    " of results and job records, and these jobs may add up to " +
                    Megabytes(more_bytes) + ": more than the quota of " +
                    Megabytes(static_cast<double>(m_info.quota_stored_bytes)) +
                    " per user (quota_stored_mb); delete what is no longer needed (dembuf delete "
                    "JOB, or --sweep SWEEP)",
                "quota=quota_stored_mb");
}

template <class Handler>
Status DembufService::Guard(const char* rpc, Handler&& handler) {
  try {
    return handler();
  } catch (...) {
    return FailureStatus(rpc);
  }
}

template <class Work>
grpc::ServerUnaryReactor* DembufService::Serve(const char* rpc,
                                               grpc::CallbackServerContext* context, Work work) {
  grpc::ServerUnaryReactor* reactor = context->DefaultReactor();
  Caller caller;
  try {
    caller = Identify(context);  // from memory: a call without a token costs no more
  } catch (...) {
    reactor->Finish(FailureStatus(rpc));
    return reactor;
  }
  const bool queued =
      m_calls.Queue(caller.name, [this, rpc, context, reactor, caller, work = std::move(work)] {
        // A caller that left while its call waited, or whose token was withdrawn meanwhile:
        // its work is not done.
        if (context->IsCancelled()) {
          reactor->Finish(Status(StatusCode::CANCELLED, "the caller left"));
          return;
        }
        if (!m_policy.StillValid(caller)) {
          reactor->Finish(TokenWithdrawn());
          return;
        }
        reactor->Finish(Guard(rpc, [&] { return work(caller); }));
      });
  if (!queued) reactor->Finish(CallsWaiting(caller));
  return reactor;
}

Status DembufService::CallsWaiting(const Caller& caller) const {
  return Status(StatusCode::RESOURCE_EXHAUSTED,
                caller.name + " has " + std::to_string(m_calls.max_waiting_per_user()) +
                    " calls waiting for the server, the most per user; send the next when one "
                    "is answered",
                "quota=calls_waiting");
}

Status DembufService::FailureStatus(const char* rpc) {
  try {
    throw;
  } catch (const AccessDenied& e) {
    return Status(e.unauthenticated() ? StatusCode::UNAUTHENTICATED : StatusCode::PERMISSION_DENIED,
                  e.what());
  } catch (const DamagedData& e) {
    m_log->error("{}: {}", rpc, e.what());
    return Status(StatusCode::DATA_LOSS, e.what());
  } catch (const StorageFull& e) {
    m_log->error("{}: the disk is full: {}", rpc, e.what());
    return DiskFull();
  } catch (const std::exception& e) {
    m_log->error("{}: {}", rpc, e.what());
    return Status(StatusCode::INTERNAL, std::string("the server failed: ") + e.what());
  } catch (...) {
    m_log->error("{}: an unknown exception", rpc);
    return Status(StatusCode::INTERNAL, "the server failed");
  }
}

DembufService::DembufService(Store& store, Executor& executor, const AccessPolicy& policy,
                             ServiceInfo info, std::shared_ptr<spdlog::logger> log)
    : m_store(store),
      m_executor(executor),
      m_policy(policy),
      m_info(std::move(info)),
      m_log(std::move(log)),
      m_watch_streams(m_info.max_watch_streams_per_user, m_info.max_watch_streams, "watch streams",
                      "max_watch_streams"),
      m_fetch_streams(m_info.max_fetch_streams_per_user, m_info.max_fetch_streams,
                      "result streams (fetch)", "max_fetch_streams"),
      m_bed_pushes(kMaxBedPushesPerUser, kMaxBedPushes, "bed pushes", "the daemon's limit"),
      m_calls(kCallThreads, kCallsRunningPerUser, kCallsWaitingPerUser) {}

bool DembufService::AnswerRetry(const std::string& owner, const std::string& request_id, bool sweep,
                                v1::SubmitJobResponse* job_answer,
                                v1::SubmitSweepResponse* sweep_answer, Status* status) {
  const std::optional<Submission> earlier = m_store.FindSubmission(owner, request_id);
  if (!earlier) return false;
  *status = Status::OK;
  if (sweep != (earlier->sweep_id != 0)) {
    *status = Invalid("request_id", request_id + " was used for a " + (sweep ? "job" : "sweep") +
                                        "; choose a new one");
    return true;
  }
  m_log->info("{} repeated request {}: answered with {} {}", owner, request_id,
              sweep ? "sweep" : "job", sweep ? earlier->sweep_id : earlier->job_id);
  if (!sweep) {
    if (const std::optional<JobRecord> job = m_store.GetJob(earlier->job_id))
      FillJob(m_store, m_executor, *job, false, job_answer->mutable_job());
    return true;
  }
  if (const std::optional<SweepRecord> record = m_store.GetSweep(earlier->sweep_id)) {
    FillSweep(m_store, *record, false, sweep_answer->mutable_sweep());
    JobFilter filter;
    filter.sweep_id = record->id;
    filter.limit = m_info.max_sweep_jobs;
    filter.with_scene = false;
    std::vector<JobRecord> jobs = m_store.ListJobs(filter);
    std::sort(jobs.begin(), jobs.end(),
              [](const JobRecord& a, const JobRecord& b) { return a.id < b.id; });
    for (const JobRecord& job : jobs) sweep_answer->add_job_ids(job.id);
  }
  return true;
}

Status DembufService::FileSubmission(const Caller& caller, const std::string& owner,
                                     const std::string& request_id,
                                     v1::SubmitJobResponse* job_answer,
                                     v1::SubmitSweepResponse* sweep_answer,
                                     const std::function<Filing()>& admit, Filing& filed) {
  auto retried = [&](Status* retry) {
    return !request_id.empty() &&
           AnswerRetry(owner, request_id, sweep_answer != nullptr, job_answer, sweep_answer, retry);
  };
  {
    std::lock_guard lock(m_submissions);
    if (Status retry; retried(&retry)) return retry;
  }
  // A user already over the stored quota is refused before the admission's work.
  if (Status s = CheckStoredQuota(owner, 0.0); !s.ok()) return s;
  Filing filing;
  try {
    filing = admit();
  } catch (const SceneError& e) {
    return FromSceneError(e);
  } catch (const ResourceError& e) {
    return OverLimits(e);
  } catch (const Cancelled&) {
    // (only a sweep's admission, run by run, asks whether the caller is still there)
    return Status(StatusCode::CANCELLED, "the caller left while its sweep was admitted");
  }
  double bytes = filing.output_bytes;
  for (const JobRecord& job : filing.jobs) bytes += static_cast<double>(JobRowBytes(job));
  // The stored quota before any stored result is read (a copy takes room as a run's result).
  if (Status s = CheckStoredQuota(owner, bytes); !s.ok()) return s;
  if (filing.reuse)
    for (JobRecord& job : filing.jobs) {
      if (filing.cancelled && filing.cancelled())
        return Status(StatusCode::CANCELLED,
                      "the caller left while its jobs were matched with stored results");
      job.reused_from = ReusableResult(caller, job);
    }
  // Filed under the lock, held for the quotas and the insert only (never for an admission):
  // two submissions at once cannot both pass a quota.
  std::lock_guard lock(m_submissions);
  // (the admission and the lookup take time: a token withdrawn meanwhile is answered nothing)
  if (!m_policy.StillValid(caller))
    return Status(StatusCode::UNAUTHENTICATED,
                  "token: revoked or replaced while the submission was admitted; nothing was "
                  "filed");
  if (Status retry; retried(&retry)) return retry;
  if (Status s = CheckStoredQuota(owner, bytes); !s.ok()) return s;
  if (Status s = FileAdmitted(owner, filing); !s.ok()) return s;
  filed = std::move(filing);
  return Status::OK;
}

Status DembufService::FileAdmitted(const std::string& owner, Filing& filing) {
  // Each pass either files everything or nothing. Results to reuse deleted since they were
  // found (the store names them all at once) make their jobs ones to run, counted again; a
  // second such pass files every job to run, which no deletion can stop.
  for (int pass = 0;; ++pass) {
    // A job answered with a stored result is done as it is filed: it neither queues nor runs.
    const auto to_run = static_cast<std::size_t>(std::count_if(
        filing.jobs.begin(), filing.jobs.end(), [](const JobRecord& j) { return !j.reused_from; }));
    if (Status s = CheckQueuedQuota(owner, to_run); !s.ok()) return s;
    try {
      m_executor.Admit(to_run, [&] {
        filing.store(filing.jobs);
        std::vector<JobRecord> queued;
        for (const JobRecord& job : filing.jobs)
          if (job.state == JobState::kQueued) queued.push_back(job);
        return queued;
      });
      return Status::OK;
    } catch (const ReusedResultGone& e) {
      m_log->info("{} results were deleted as {} filed jobs reusing them: they run", e.gone.size(),
                  owner);
      const std::set<std::int64_t> gone(e.gone.begin(), e.gone.end());
      for (JobRecord& job : filing.jobs)
        if (job.reused_from != 0 && (pass > 0 || gone.count(job.reused_from) != 0))
          job = Unreused(std::move(job));
    } catch (const QueueFull& e) {
      return Status(StatusCode::RESOURCE_EXHAUSTED, e.what());
    } catch (const StorageFull& e) {
      m_log->error("a request found the disk full: {}", e.what());
      return DiskFull();
    }
  }
}

grpc::ServerUnaryReactor* DembufService::SubmitJob(grpc::CallbackServerContext* context,
                                                   const v1::SubmitJobRequest* request,
                                                   v1::SubmitJobResponse* response) {
  return Serve("SubmitJob", context, [=, this](const Caller& caller) -> Status {
    std::string owner;
    if (Status s = CheckSubmission(caller, *request, m_info.notify, &owner); !s.ok()) return s;
    if (Status s = CheckNotifyRoom(request->notify(), owner); !s.ok()) return s;
    auto admit = [&] {
      const AdmittedJob admitted =
          AdmitJob(request->scene(), BedFileOf(request->scene(), owner), m_info.job_limits);
      std::string name = request->name();
      if (name.empty())
        name = request->scene().preset().empty() ? "job" : request->scene().preset();
      Filing filing;
      filing.output_bytes = admitted.output_bytes;
      filing.warnings = SceneWarnings(admitted.scene);
      JobRecord& job = filing.jobs.emplace_back(MakeJobRecord(admitted.scene, owner, name));
      job.bed_file = request->scene().bed_file();
      job.command_line = KeptCommandLine(context, request->command_line());
      job.notify = request->notify();
      filing.reuse = !request->no_reuse();
      filing.cancelled = [context] { return context->IsCancelled(); };
      filing.store = [&](std::vector<JobRecord>& jobs) {
        m_store.AddJob(jobs.front(), request->request_id());
      };
      return filing;
    };
    Filing filed;
    if (Status s =
            FileSubmission(caller, owner, request->request_id(), response, nullptr, admit, filed);
        !s.ok() || filed.jobs.empty())
      return s;
    const JobRecord& job = filed.jobs.front();
    m_log->info("job {} submitted by {}: {}", job.id, job.owner, job.name);
    FillJob(m_store, m_executor, job, false, response->mutable_job());
    for (const std::string& w : filed.warnings) response->add_warnings(w);
    return Status::OK;
  });
}

grpc::ServerUnaryReactor* DembufService::SubmitSweep(grpc::CallbackServerContext* context,
                                                     const v1::SubmitSweepRequest* request,
                                                     v1::SubmitSweepResponse* response) {
  return Serve("SubmitSweep", context, [=, this](const Caller& caller) -> Status {
    std::string owner;
    if (Status s = CheckSubmission(caller, *request, m_info.notify, &owner); !s.ok()) return s;
    if (Status s = CheckNotifyRoom(request->notify(), owner); !s.ok()) return s;
    SweepRecord sweep;
    auto admit = [&] {
      const AdmittedSweep admitted = AdmitSweep(
          *request, [&] { return BedFileOf(request->base(), owner); }, m_info.job_limits,
          static_cast<std::size_t>(m_info.max_sweep_jobs),
          [context] { return context->IsCancelled(); });
      sweep.owner = owner;
      sweep.name = request->name().empty() ? "sweep" : request->name();
      sweep.axes = admitted.axes;
      sweep.notify = request->notify();
      Filing filing;
      filing.output_bytes = admitted.output_bytes;
      const std::string command_line = KeptCommandLine(context, request->command_line());
      const std::vector<SweepRun>& runs = admitted.runs;
      for (std::size_t k : StartOrder(LoadsOf(runs))) {
        for (const std::string& w : SceneWarnings(runs[k].scene))
          if (std::find(filing.warnings.begin(), filing.warnings.end(), w) == filing.warnings.end())
            filing.warnings.push_back(w);
        JobRecord& job =
            filing.jobs.emplace_back(MakeJobRecord(runs[k].scene, sweep.owner, runs[k].name));
        job.bed_file = request->base().bed_file();
        job.sweep_index = static_cast<int>(runs[k].index);
        job.sweep_values = runs[k].values;
        job.command_line = command_line;
      }
      filing.reuse = !request->no_reuse();
      filing.cancelled = [context] { return context->IsCancelled(); };
      filing.store = [&](std::vector<JobRecord>& jobs) {
        m_store.AddSweep(sweep, jobs, request->request_id());
      };
      return filing;
    };
    Filing filed;
    if (Status s =
            FileSubmission(caller, owner, request->request_id(), nullptr, response, admit, filed);
        !s.ok() || filed.jobs.empty())
      return s;
    m_log->info("sweep {} submitted by {}: {} jobs", sweep.id, sweep.owner, filed.jobs.size());
    FillSweep(m_store, sweep, false, response->mutable_sweep());
    for (const JobRecord& job : filed.jobs) response->add_job_ids(job.id);
    for (const std::string& w : filed.warnings) response->add_warnings(w);
    return Status::OK;
  });
}

grpc::ServerUnaryReactor* DembufService::GetJob(grpc::CallbackServerContext* context,
                                                const v1::GetJobRequest* request,
                                                v1::Job* response) {
  return Serve("GetJob", context, [=, this](const Caller& caller) -> Status {
    const auto job = m_store.GetJob(request->id());
    if (!job) return Status(StatusCode::NOT_FOUND, "id: no job " + std::to_string(request->id()));
    AccessPolicy::Require(caller, Action::kRead, job->owner, "id: job " + std::to_string(job->id));
    FillJob(m_store, m_executor, *job, true, response);
    return Status::OK;
  });
}

grpc::ServerUnaryReactor* DembufService::GetSweep(grpc::CallbackServerContext* context,
                                                  const v1::GetSweepRequest* request,
                                                  v1::Sweep* response) {
  return Serve("GetSweep", context, [=, this](const Caller& caller) -> Status {
    const auto sweep = m_store.GetSweep(request->id());
    if (!sweep)
      return Status(StatusCode::NOT_FOUND, "id: no sweep " + std::to_string(request->id()));
    AccessPolicy::Require(caller, Action::kRead, sweep->owner,
                          "id: sweep " + std::to_string(sweep->id));
    FillSweep(m_store, *sweep, request->aggregates(), response);
    return Status::OK;
  });
}

grpc::ServerUnaryReactor* DembufService::ListJobs(grpc::CallbackServerContext* context,
                                                  const v1::ListJobsRequest* request,
                                                  v1::ListJobsResponse* response) {
  return Serve("ListJobs", context, [=, this](const Caller& caller) -> Status {
    JobFilter filter;
    if (request->state() != v1::JOB_STATE_UNSPECIFIED) {
      filter.state = FromProto(request->state());
      if (!filter.state) return Invalid("state", "unknown job state");
    }
    if (Status s = CheckOwner(request->owner()); !s.ok()) return s;
    if (request->limit() < 0 || request->limit() > 100000)
      return Invalid("limit", "must be 0 (100) to 100000");
    filter.owner = AccessPolicy::ListedOwner(caller, request->owner());
    filter.sweep_id = request->sweep_id();
    filter.limit = request->limit() == 0 ? 100 : request->limit();
    filter.with_scene = false;
    filter.max_bytes = kMaxListAnswerBytes;
    bool over = false;
    for (const JobRecord& job : m_store.ListJobs(filter, &over)) {
      if (over) return ListTooLarge(filter.limit, "jobs");
      FillJob(m_store, m_executor, job, false, response->add_jobs());
    }
    return Status::OK;
  });
}

grpc::ServerUnaryReactor* DembufService::ListSweeps(grpc::CallbackServerContext* context,
                                                    const v1::ListSweepsRequest* request,
                                                    v1::ListSweepsResponse* response) {
  return Serve("ListSweeps", context, [=, this](const Caller& caller) -> Status {
    if (Status s = CheckOwner(request->owner()); !s.ok()) return s;
    if (request->limit() < 0 || request->limit() > 100000)
      return Invalid("limit", "must be 0 (100) to 100000");
    const std::string owner = AccessPolicy::ListedOwner(caller, request->owner());
    const int limit = request->limit() == 0 ? 100 : request->limit();
    if (!FillSweepList(m_store, owner, limit, response->mutable_sweeps()))
      return ListTooLarge(limit, "sweeps");
    return Status::OK;
  });
}

Status DembufService::TargetedJobs(const Caller& caller, Action action, std::int64_t job_id,
                                   std::int64_t sweep_id, std::vector<JobRecord>* targets) {
  if ((job_id != 0) == (sweep_id != 0)) return Invalid("job_id", "give either job_id or sweep_id");
  if (job_id != 0) {
    const auto job = m_store.GetJob(job_id);
    if (!job) return Status(StatusCode::NOT_FOUND, "job_id: no job " + std::to_string(job_id));
    AccessPolicy::Require(caller, action, job->owner, "job_id: job " + std::to_string(job_id));
    targets->push_back(*job);
    return Status::OK;
  }
  const auto sweep = m_store.GetSweep(sweep_id);
  if (!sweep)
    return Status(StatusCode::NOT_FOUND, "sweep_id: no sweep " + std::to_string(sweep_id));
  AccessPolicy::Require(caller, action, sweep->owner,
                        "sweep_id: sweep " + std::to_string(sweep_id));
  JobFilter filter;
  filter.sweep_id = sweep_id;
  filter.limit = 1000000;
  filter.with_scene = false;  // (their states and ids are what is wanted)
  *targets = m_store.ListJobs(filter);
  return Status::OK;
}

grpc::ServerUnaryReactor* DembufService::Cancel(grpc::CallbackServerContext* context,
                                                const v1::CancelRequest* request,
                                                v1::CancelResponse* response) {
  return Serve("Cancel", context, [=, this](const Caller& caller) -> Status {
    std::vector<JobRecord> targets;
    if (Status s =
            TargetedJobs(caller, Action::kCancel, request->job_id(), request->sweep_id(), &targets);
        !s.ok())
      return s;
    int cancelled = 0;
    try {
      for (const JobRecord& job : targets)
        if (!IsFinal(job.state) && m_executor.Cancel(job.id)) ++cancelled;
    } catch (const StorageFull& e) {
      m_log->error("a request found the disk full: {}", e.what());
      return DiskFull();
    }
    if (request->job_id() != 0 && cancelled == 0)
      return Status(StatusCode::FAILED_PRECONDITION,
                    "job_id: job " + std::to_string(request->job_id()) + " has already ended (" +
                        StateName(targets.front().state) + ")");
    response->set_cancelled(cancelled);
    return Status::OK;
  });
}

grpc::ServerUnaryReactor* DembufService::Delete(grpc::CallbackServerContext* context,
                                                const v1::DeleteRequest* request,
                                                v1::DeleteResponse* response) {
  return Serve("Delete", context, [=, this](const Caller& caller) -> Status {
    std::vector<JobRecord> targets;
    if (Status s =
            TargetedJobs(caller, Action::kDelete, request->job_id(), request->sweep_id(), &targets);
        !s.ok())
      return s;
    const std::string what = request->job_id() != 0
                                 ? "job_id: job " + std::to_string(request->job_id())
                                 : "sweep_id: sweep " + std::to_string(request->sweep_id());
    // A job that has not ended keeps adding to its results: it is cancelled first, and a job
    // cancelled is deleted once it has stopped (its worker may still be writing).
    std::vector<std::int64_t> ids;
    int unfinished = 0;
    for (const JobRecord& job : targets) {
      if (!IsFinal(job.state) || m_executor.Live(job.id)) ++unfinished;
      ids.push_back(job.id);
    }
    if (unfinished > 0) {
      const JobState state = targets.front().state;
      const std::string why =
          request->sweep_id() != 0
              ? what + " has " + std::to_string(unfinished) + " job(s) not ended"
          : IsFinal(state) ? what + " is still stopping"
                           : what + " has not ended (" + StateName(state) + ")";
      const std::string cancel =
          request->sweep_id() != 0 ? "dembuf cancel --sweep " + std::to_string(request->sweep_id())
                                   : "dembuf cancel " + std::to_string(request->job_id());
      return Status(StatusCode::FAILED_PRECONDITION,
                    why + ": cancel first (" + cancel +
                        "), and delete once stopped (a cancelled job stops within seconds)");
    }
    const std::int64_t freed = m_store.DeleteJobs(ids, request->sweep_id());
    m_log->info("{} deleted {} job(s) ({}): {} bytes of results", caller.name, ids.size(), what,
                freed);
    response->set_deleted(static_cast<int>(ids.size()));
    response->set_freed_bytes(freed);
    return Status::OK;
  });
}

grpc::ServerWriteReactor<v1::WatchJobResponse>* DembufService::WatchJob(
    grpc::CallbackServerContext* context, const v1::WatchJobRequest* request) {
  using Reactor = StreamReactor<v1::WatchJobResponse>;
  std::optional<StreamLimits::Place> place;
  const std::int64_t id = request->id();
  Caller caller;
  const Status opened = Guard("WatchJob", [&]() -> Status {
    caller = Identify(context);
    if (request->from_index() < 0) return Invalid("from_index", "must be >= 0");
    const auto job = m_store.GetJob(id);
    if (!job) return Status(StatusCode::NOT_FOUND, "id: no job " + std::to_string(id));
    AccessPolicy::Require(caller, Action::kWatch, job->owner, "id: job " + std::to_string(id));
    std::string why;
    std::optional<StreamLimits::Place> taken = m_watch_streams.Take(caller, &why);
    if (!taken)
      return Status(StatusCode::RESOURCE_EXHAUSTED,
                    "watch streams: " + why + "; close one, or wait for the jobs to end");
    place.emplace(std::move(*taken));
    return Status::OK;
  });
  if (!opened.ok()) return Reactor::Refuse(context, m_clock, opened);

  // Samples as they come; while the job runs its progress twice a second, while it waits in
  // the queue its state every two seconds. Between looks the stream waits on the clock.
  struct Watch {
    Watch(JobFeed f, std::int64_t from) : feed(std::move(f)), next(from) {}
    JobFeed feed;
    std::int64_t next;
    std::chrono::steady_clock::time_point last_message{};
    bool ended = false;
  };
  auto watch = std::make_shared<Watch>(JobFeed(m_store, m_executor, id), request->from_index());
  return Reactor::Start(
      context, m_clock, m_info.stream_write_timeout, std::move(place),
      [this, watch, id, caller](v1::WatchJobResponse* message) -> StreamStep {
        try {
          if (watch->ended) return StreamStep::Finish(Status::OK);
          if (!m_policy.StillValid(caller)) return StreamStep::Finish(TokenWithdrawn());
          const FeedRead read =
              watch->feed.Read(watch->next, kSamplesPerMessage, std::chrono::milliseconds(0));
          if (!read.found)
            return StreamStep::Finish(
                Status(StatusCode::NOT_FOUND, "id: no job " + std::to_string(id)));
          const auto now = std::chrono::steady_clock::now();
          const bool active =
              read.state == JobState::kRunning || read.state == JobState::kPreparingBed;
          const auto pace = active ? std::chrono::milliseconds(500) : std::chrono::seconds(2);
          if (read.samples.empty() && !read.ended && now - watch->last_message < pace)
            return StreamStep::Wait(active ? std::chrono::milliseconds(100)
                                           : std::chrono::milliseconds(250));
          message->Clear();
          message->set_first_index(watch->next);
          for (const ImpactSample& s : read.samples) FillSample(s, message->add_samples());
          message->set_state(ToProto(read.state));
          FillProgress(read.progress, message->mutable_progress());
          watch->next += static_cast<std::int64_t>(read.samples.size());
          watch->last_message = now;
          watch->ended = read.ended;
          return StreamStep::Write();
        } catch (...) {
          return StreamStep::Finish(FailureStatus("WatchJob"));
        }
      });
}

Status DembufService::FinishedJobOfCaller(const Caller& caller, std::int64_t id,
                                          std::optional<JobRecord>* job) {
  *job = m_store.GetJob(id);
  if (!*job) return Status(StatusCode::NOT_FOUND, "id: no job " + std::to_string(id));
  AccessPolicy::Require(caller, Action::kFetch, (*job)->owner, "id: job " + std::to_string(id));
  if (!IsFinal((*job)->state))
    return Status(StatusCode::FAILED_PRECONDITION,
                  "id: job " + std::to_string(id) + " is " + StateName((*job)->state) +
                      "; results come when it ends (watch it meanwhile)");
  return Status::OK;
}

Status DembufService::OpenFetchStream(const char* rpc, const grpc::ServerContextBase* context,
                                      std::int64_t id, Caller* caller,
                                      std::optional<JobRecord>* job,
                                      std::optional<StreamLimits::Place>* place) {
  return Guard(rpc, [&]() -> Status {
    *caller = Identify(context);
    if (Status s = FinishedJobOfCaller(*caller, id, job); !s.ok()) return s;
    std::string why;
    std::optional<StreamLimits::Place> taken = m_fetch_streams.Take(*caller, &why);
    if (!taken)
      return Status(StatusCode::RESOURCE_EXHAUSTED,
                    "result streams: " + why + "; wait for your other fetches to end");
    place->emplace(std::move(*taken));
    return Status::OK;
  });
}

grpc::ServerUnaryReactor* DembufService::FetchResults(grpc::CallbackServerContext* context,
                                                      const v1::FetchResultsRequest* request,
                                                      v1::FetchResultsResponse* response) {
  return Serve("FetchResults", context, [=, this](const Caller& caller) -> Status {
    std::optional<JobRecord> job;
    if (Status s = FinishedJobOfCaller(caller, request->id(), &job); !s.ok()) return s;
    // A damaged summary fails the fetch (DATA_LOSS) rather than coming back empty.
    FillJob(m_store, m_executor, *job, true, response->mutable_job(),
            /*damaged_summary_fails=*/true);
    const std::int64_t length = m_store.ResultSeriesLength(job->id);
    response->set_series_length(length);
    // A short series comes with the answer; a long one is streamed (FetchSeries).
    if (length <= kMaxSamplesInResults)
      for (const ImpactSample& s : m_store.ReadResultSeries(job->id, 0, length))
        FillSample(s, response->add_samples());
    return Status::OK;
  });
}

grpc::ServerWriteReactor<v1::SeriesChunk>* DembufService::FetchSeries(
    grpc::CallbackServerContext* context, const v1::FetchSeriesRequest* request) {
  using Reactor = StreamReactor<v1::SeriesChunk>;
  if (request->from_index() < 0)
    return Reactor::Refuse(context, m_clock, Invalid("from_index", "must be >= 0"));
  Caller caller;
  std::optional<JobRecord> job;
  std::optional<StreamLimits::Place> place;
  if (Status s = OpenFetchStream("FetchSeries", context, request->id(), &caller, &job, &place);
      !s.ok())
    return Reactor::Refuse(context, m_clock, s);
  // Piece by piece from the store, the store's lock held for one piece at a time: a series of
  // any length is sent without holding it, or the store, whole.
  constexpr std::int64_t kSamplesPerChunk = 8192;
  struct Series {
    std::int64_t id, total, next;
    bool done = false;
  };
  const std::int64_t total = m_store.ResultSeriesLength(job->id);
  auto series =
      std::make_shared<Series>(Series{job->id, total, std::min(request->from_index(), total)});
  return Reactor::Start(context, m_clock, m_info.stream_write_timeout, std::move(place),
                        [this, series, caller](v1::SeriesChunk* chunk) -> StreamStep {
                          try {
                            if (series->done) return StreamStep::Finish(Status::OK);
                            if (!m_policy.StillValid(caller))
                              return StreamStep::Finish(TokenWithdrawn());
                            chunk->Clear();
                            chunk->set_first_index(series->next);
                            chunk->set_total(series->total);
                            for (const ImpactSample& s : m_store.ReadResultSeries(
                                     series->id, series->next, kSamplesPerChunk))
                              FillSample(s, chunk->add_samples());
                            series->next += chunk->samples_size();
                            // The end, or a series shorter than counted: this chunk is the last.
                            series->done =
                                chunk->samples_size() == 0 || series->next >= series->total;
                            return StreamStep::Write();
                          } catch (...) {
                            return StreamStep::Finish(FailureStatus("FetchSeries"));
                          }
                        });
}

grpc::ServerWriteReactor<v1::FileChunk>* DembufService::FetchFiles(
    grpc::CallbackServerContext* context, const v1::FetchFilesRequest* request) {
  using Reactor = StreamReactor<v1::FileChunk>;
  Caller caller;
  std::optional<JobRecord> job;
  std::optional<StreamLimits::Place> place;
  if (Status s = OpenFetchStream("FetchFiles", context, request->id(), &caller, &job, &place);
      !s.ok())
    return Reactor::Refuse(context, m_clock, s);
  // Piece by piece from the store: a file of any size is sent without holding it whole.
  constexpr std::int64_t kChunkBytes = 1 << 20;
  struct Files {
    std::int64_t id;
    std::vector<JobFileInfo> files;
    std::size_t file = 0;
    std::int64_t offset = 0;
  };
  auto files = std::make_shared<Files>(Files{job->id, m_store.JobFiles(job->id)});
  return Reactor::Start(
      context, m_clock, m_info.stream_write_timeout, std::move(place),
      [this, files, caller](v1::FileChunk* chunk) -> StreamStep {
        try {
          if (files->file >= files->files.size()) return StreamStep::Finish(Status::OK);
          if (!m_policy.StillValid(caller)) return StreamStep::Finish(TokenWithdrawn());
          const JobFileInfo& file = files->files[files->file];
          chunk->Clear();
          chunk->set_path(file.path);
          chunk->set_size(file.size);
          chunk->set_offset(files->offset);
          chunk->set_data(m_store.ReadJobFile(files->id, file.path, files->offset, kChunkBytes));
          files->offset += static_cast<std::int64_t>(chunk->data().size());
          // Every file sends at least one piece; an empty piece ends a file that shrank.
          if (chunk->data().empty() || files->offset >= file.size) {
            ++files->file;
            files->offset = 0;
          }
          return StreamStep::Write();
        } catch (...) {
          return StreamStep::Finish(FailureStatus("FetchFiles"));
        }
      });
}

grpc::ServerUnaryReactor* DembufService::ServerInfo(grpc::CallbackServerContext* context,
                                                    const v1::ServerInfoRequest*,
                                                    v1::ServerInfoResponse* response) {
  // Anyone known to the server may ask; where its files are, only an admin learns.
  return Serve("ServerInfo", context, [=, this](const Caller& caller) -> Status {
    response->set_version(kVersion);
    const ExecutorInfo executor = m_executor.info();
    response->set_executor(executor.kind);
    response->set_notify(m_info.notify);
    response->set_workers(executor.workers);
    response->set_threads_per_job(executor.threads_per_job);
    response->set_queue_depth(m_executor.queued());
    response->set_queue_limit(executor.queue_limit);
    response->set_running(m_executor.running());
    if (caller.admin) response->set_database(m_info.database);
    response->set_stored_bytes(m_store.StoredBytesOf(caller.name));
    response->set_quota_stored_bytes(m_info.quota_stored_bytes);
    response->set_queued_jobs(m_store.CountQueuedBy(caller.name));
    response->set_quota_queued_jobs(m_info.quota_queued_jobs);
    response->set_host(m_info.host);
    response->set_started_at(m_info.started_at);
    return Status::OK;
  });
}

std::optional<BedFile> DembufService::BedFileOf(const v1::SceneSpec& spec,
                                                const std::string& owner) {
  const std::string& sha256 = spec.bed_file();
  if (sha256.empty()) return std::nullopt;
  const bool hex = sha256.size() == 64 && std::all_of(sha256.begin(), sha256.end(), [](char c) {
                     return std::isdigit(static_cast<unsigned char>(c)) || (c >= 'a' && c <= 'f');
                   });
  if (!hex) throw SceneError("bed_file", "must be a SHA-256 in 64 lowercase hex digits");
  std::optional<BedFile> file = m_store.GetBedFile(owner, sha256);
  if (!file)
    throw SceneError("bed_file", owner + " sent no bed file " + sha256 +
                                     " to this server: send it first (PushBed, kind \"file\")");
  // The submission then checks it as a local import is checked (lines, units, container,
  // overlaps): the job's resource estimate reads it so, and a bad file is refused at once.
  return file;
}

grpc::ServerReadReactor<v1::BedPiece>* DembufService::PushBed(grpc::CallbackServerContext* context,
                                                              v1::PushBedResponse* response) {
  std::optional<StreamLimits::Place> place;
  Caller caller;
  std::string why;
  try {
    caller = Identify(context);
    if (std::optional<StreamLimits::Place> taken = m_bed_pushes.Take(caller, &why))
      place.emplace(std::move(*taken));
  } catch (...) {
    return BedPushReactor::Refuse(FailureStatus("PushBed"));
  }
  if (!place)
    return BedPushReactor::Refuse(
        Status(StatusCode::RESOURCE_EXHAUSTED, "bed pushes: " + why + "; send one at a time"));
  // The bed is checked and kept by the CallPool, in the caller's turn, not on gRPC's thread.
  return BedPushReactor::Start(
      context, m_clock, m_info.stream_write_timeout, m_info.max_bed_push_bytes, std::move(place),
      [this, caller, response](const v1::BedPiece& first, std::string data,
                               BedPushReactor::Answer answer) {
        auto bed = std::make_shared<std::pair<v1::BedPiece, std::string>>(first, std::move(data));
        const bool queued = m_calls.Queue(caller.name, [this, caller, response, bed, answer] {
          answer(Guard("PushBed", [&] {
            if (!m_policy.StillValid(caller)) return TokenWithdrawn();
            return ReceiveBed(caller, bed->first, std::move(bed->second), response);
          }));
        });
        if (!queued) answer(CallsWaiting(caller));
      });
}

Status DembufService::ReceiveBed(const Caller& caller, const v1::BedPiece& first, std::string data,
                                 v1::PushBedResponse* response) {
  if (first.kind() == "file") {
    if (Status s = CheckOwner(first.owner()); !s.ok()) return s;
    const std::string owner = AccessPolicy::OwnerFor(caller, first.owner());
    AccessPolicy::Require(caller, Action::kSubmit, owner, "bed files of " + owner);
    if (!IsPlainBedFileName(first.name()))
      return Invalid("name", "\"" + PrintableText(first.name().substr(0, 120)) +
                                 "\" must be 1 to " + std::to_string(kMaxBedFileNameBytes) +
                                 " letters, digits, '.', '_' or '-', not starting with '.'");
    const std::string sha256 = Sha256Hex(data);
    bool added = false;
    try {
      added = m_store.PutBedFile(
          {owner, sha256, first.name(), std::make_shared<const std::string>(std::move(data))},
          kBedFileRoomPerPush * m_info.max_bed_push_bytes);
    } catch (const BedFilesFull& e) {
      return Status(StatusCode::RESOURCE_EXHAUSTED, std::string("owner: ") + e.what());
    }
    m_log->info("bed file {} ({}) {} by {}", sha256, first.name(), added ? "sent" : "sent again",
                owner);
    response->set_hash(sha256);
    response->set_had_it(!added);
    return Status::OK;
  }
  if (first.kind() != "prepared")
    return Invalid("kind", "\"" + PrintableText(first.kind().substr(0, 40)) +
                               "\" must be \"prepared\" or \"file\"");
  AccessPolicy::Require(caller, Action::kShareBed, "", "put prepared beds in the shared bed cache");
  PreparedBed bed;
  try {
    // The scene is admitted as a job's is: it may name no file on the daemon's disk, and
    // what it costs must be within the limits.
    const Scene scene = LoadSceneText(first.scene_toml(), "scene_toml");
    AdmitScene(scene, std::nullopt, m_info.job_limits);
    bed = ParseBed(data, "the pushed bed");
    CheckPreparedBed(bed, scene);
  } catch (const SceneError& e) {
    return FromSceneError(e);
  } catch (const ResourceError& e) {
    return OverLimits(e);
  } catch (const std::runtime_error& e) {  // ParseBed: damaged or foreign bytes
    return Invalid("data", e.what());
  }
  response->set_hash(bed.hash);
  response->set_stage(bed.stage);
  response->set_beads(static_cast<std::int64_t>(bed.beads.size()));
  if (m_store.beds().Contains(bed.hash)) {
    response->set_had_it(true);
    return Status::OK;
  }
  m_store.beds().Save(bed);
  m_executor.AddBed(bed);
  m_log->info("{} bed {} ({} beads) pushed by {}", bed.stage, bed.hash, bed.beads.size(),
              caller.name);
  return Status::OK;
}

}  // namespace dembuf::server
