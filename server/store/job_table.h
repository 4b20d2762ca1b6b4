// The jobs the daemon keeps: their records and states, the request ids that filed them
// (submissions) and their events, a table of the store (store.h).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "store/connection.h"
#include "store/records.h"

namespace dembuf::server {

/// Inserts a job's row (in the caller's transaction) and sets its id and creation time: for
/// the tables that file jobs (a job alone, a sweep's jobs). A job to be answered with another's
/// result (`reused_from`) is filed done with a copy of it; ReusedResultGone when that result has
/// gone (the caller's transaction then rolls back).
void InsertJob(Database& db, JobRecord& job);
/// Throws ReusedResultGone naming every result the jobs were to reuse that is no longer done
/// and stored (in the caller's transaction, before any job is inserted).
void RequireReusedResults(Database& db, const std::vector<JobRecord>& jobs);
/// Notes (in the caller's transaction) that `owner`'s request id filed this job or sweep, for
/// FindSubmission; nothing for an empty request id.
void RecordSubmission(Database& db, const std::string& owner, const std::string& request_id,
                      const Submission& filed, const std::string& at);

/// Jobs, their submissions and events.
class JobTable {
 public:
  /// Adds one job; sets its id. A `request_id` as for AddSweep.
  void AddJob(JobRecord& job, const std::string& request_id = "");
  /// Done jobs (at most `limit`, originals before copies, newest first) of this scene (its hash
  /// and its text: the 64-bit hash finds them, and is no defence against a collision made on
  /// purpose) and bed file ("" for none), of `owner` only when given: results a new job of the
  /// scene may reuse.
  std::vector<JobRecord> DoneJobsOfScene(const std::string& scene_hash,
                                         const std::string& scene_toml, const std::string& bed_file,
                                         const std::optional<std::string>& owner, int limit = 4);
  /// The job or sweep `owner` filed with this request id, if any.
  std::optional<Submission> FindSubmission(const std::string& owner, const std::string& request_id);
  std::optional<JobRecord> GetJob(std::int64_t id);
  /// The newest jobs the filter takes; `over_max_bytes`, when given, says whether the listing
  /// stopped at filter.max_bytes.
  std::vector<JobRecord> ListJobs(const JobFilter& filter, bool* over_max_bytes = nullptr);
  int CountQueued();
  int CountQueuedBy(const std::string& owner);
  /// Queued jobs, oldest first.
  std::vector<JobRecord> QueuedJobs();
  /// Jobs queued, preparing or running, oldest first.
  std::vector<JobRecord> UnfinishedJobs();
  /// A worker took the job: state, start time, host and code version, one more attempt; the
  /// samples of an earlier attempt are dropped.
  void MarkStarted(std::int64_t id, JobState state, const std::string& host,
                   const std::string& code_version);
  void SetState(std::int64_t id, JobState state, const std::string& error = "");
  /// The Slurm job that runs each of `jobs` (the Slurm executor): one job, task -1, or the
  /// tasks of one job array, each job's task its id less `array_base`. One transaction.
  void SetSlurmId(const std::vector<std::int64_t>& jobs, std::int64_t slurm_id,
                  std::int64_t array_base = -1);
  /// Keeps the nonce given to the jobs' Slurm job (the Slurm executor), before it is submitted.
  void SetResultNonce(const std::vector<std::int64_t>& jobs, const std::string& nonce);
  /// Notes that the job's user asked to cancel it.
  void RequestCancel(std::int64_t id);
  /// At start: jobs left preparing or running by a daemon that died go back to the queue,
  /// with a note, unless this is the second time (they may be what killed it): those fail.
  InterruptedJobs RequeueInterrupted(const std::string& reason);
  /// Appends to the provenance log.
  void LogEvent(std::int64_t job_id, const std::string& message);

 protected:
  explicit JobTable(Connection& connection) : m_connection(connection) {}
  /// Before checksums (schema version 8), a client could leave its token in a kept command
  /// line: the upgrade hides it, in the jobs' rows and in the summaries that repeat it.
  static void HideTokensInCommandLines(Database& db);

 private:
  Connection& m_connection;
};

}  // namespace dembuf::server
