#include "store/job_table.h"

#include <nlohmann/json.hpp>
#include <set>
#include <tuple>

#include "dembuf/study/files/provenance.h"
#include "dembuf/study/files/run_output.h"
#include "store/notification_table.h"
#include "store/result_table.h"

namespace dembuf::server {

namespace {

const char* const kJobColumns =
    "id, IFNULL(sweep_id, 0), sweep_index, sweep_values_json, owner, name, state, error, "
    "scene_toml, scene_hash, bed_hash, source_hash, attempts, created_at, started_at, "
    "finished_at, host, code_version, slurm_id, cancel_requested, bed_file, result_nonce, "
    "peak_plate_force_N, P_N, slurm_task, reused_from, command_line";
// The same for a listing, which shows no scene: its text is not read ('' in its place).
const char* const kListedJobColumns =
    "id, IFNULL(sweep_id, 0), sweep_index, sweep_values_json, owner, name, state, error, "
    "'', scene_hash, bed_hash, source_hash, attempts, created_at, started_at, "
    "finished_at, host, code_version, slurm_id, cancel_requested, bed_file, result_nonce, "
    "peak_plate_force_N, P_N, slurm_task, reused_from, command_line";
// How many kJobColumns names: a column selected after them has this index.
constexpr int kJobColumnCount = 27;

JobRecord ReadJobRow(Statement& s) {
  JobRecord j;
  j.id = s.Int(0);
  j.sweep_id = s.Int(1);
  j.sweep_index = static_cast<int>(s.Int(2));
  j.sweep_values = nlohmann::json::parse(s.Text(3)).get<std::vector<std::string>>();
  j.owner = s.Text(4);
  j.name = s.Text(5);
  j.state = ParseState(s.Text(6)).value_or(JobState::kFailed);
  j.error = s.Text(7);
  j.scene_toml = s.Text(8);
  j.scene_hash = s.Text(9);
  j.bed_hash = s.Text(10);
  j.source_hash = s.Text(11);
  j.attempts = static_cast<int>(s.Int(12));
  j.created_at = s.Text(13);
  j.started_at = s.Text(14);
  j.finished_at = s.Text(15);
  j.host = s.Text(16);
  j.code_version = s.Text(17);
  j.slurm_id = s.Int(18);
  j.cancel_requested = s.Int(19) != 0;
  j.bed_file = s.Text(20);
  j.result_nonce = s.Text(21);
  j.peak_plate_force_N = s.Real(22);
  j.P_N = s.Real(23);
  j.slurm_task = static_cast<int>(s.Int(24));
  j.reused_from = s.Int(25);
  j.command_line = s.Text(kJobColumnCount - 1);
  return j;
}

}  // namespace

const char* StateName(JobState state) {
  switch (state) {
    case JobState::kQueued:
      return "queued";
    case JobState::kPreparingBed:
      return "preparing_bed";
    case JobState::kRunning:
      return "running";
    case JobState::kDone:
      return "done";
    case JobState::kFailed:
      return "failed";
    case JobState::kCancelled:
      return "cancelled";
  }
  return "unknown";
}

std::optional<JobState> ParseState(const std::string& name) {
  for (JobState s : {JobState::kQueued, JobState::kPreparingBed, JobState::kRunning,
                     JobState::kDone, JobState::kFailed, JobState::kCancelled})
    if (name == StateName(s)) return s;
  return std::nullopt;
}

void InsertJob(Database& db, JobRecord& job) {
  job.created_at = report::UtcNow();
  // Its id after every job's, deleted ones' too (Store::DeleteJobs notes the largest).
  Statement& s = db.Prepare(
      "INSERT INTO jobs (id, sweep_id, sweep_index, sweep_values_json, owner, name, state, "
      "scene_toml, scene_hash, bed_hash, source_hash, created_at, command_line, bed_file) "
      "VALUES (max(IFNULL((SELECT max(id) FROM jobs), 0), IFNULL((SELECT CAST(value AS INTEGER) "
      "FROM meta WHERE key = 'deleted_job_id_max'), 0)) + 1, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, "
      "?, ?)");
  if (job.sweep_id != 0) {
    s.Bind(job.sweep_id, job.sweep_index, nlohmann::json(job.sweep_values).dump(), job.owner,
           job.name, StateName(job.state), job.scene_toml, job.scene_hash, job.bed_hash,
           job.source_hash, job.created_at, job.command_line, job.bed_file);
  } else {
    s.Bind(std::nullopt, job.sweep_index, nlohmann::json(job.sweep_values).dump(), job.owner,
           job.name, StateName(job.state), job.scene_toml, job.scene_hash, job.bed_hash,
           job.source_hash, job.created_at, job.command_line, job.bed_file);
  }
  s.Run();
  job.id = db.LastInsertId();
  // A result to reuse that has gone since it was found (deleted): nothing of this filing stays,
  // so that the submission counts the job among those to run before it files it again.
  if (job.reused_from != 0 && !CopyResultIn(db, job.reused_from, job.id))
    throw ReusedResultGone({job.reused_from});
  if (job.reused_from != 0) job.state = JobState::kDone;
}

void RequireReusedResults(Database& db, const std::vector<JobRecord>& jobs) {
  std::set<std::int64_t> originals;
  for (const JobRecord& job : jobs)
    if (job.reused_from != 0) originals.insert(job.reused_from);
  std::vector<std::int64_t> gone;
  for (std::int64_t id : originals) {
    Statement& s = db.Prepare(std::string("SELECT 1 FROM jobs WHERE ") + kJobWithStoredResult);
    s.Bind(id, id);
    if (!s.Step()) gone.push_back(id);
    s.Reset();
  }
  if (!gone.empty()) throw ReusedResultGone(std::move(gone));
}

void RecordSubmission(Database& db, const std::string& owner, const std::string& request_id,
                      const Submission& filed, const std::string& at) {
  if (request_id.empty()) return;
  db.Prepare(
        "INSERT INTO submissions (owner, request_id, job_id, sweep_id, created_at) "
        "VALUES (?, ?, ?, ?, ?)")
      .Bind(owner, request_id, filed.job_id, filed.sweep_id, at)
      .Run();
}

void JobTable::AddJob(JobRecord& job, const std::string& request_id) {
  Connection::Writing db = m_connection.Write();
  RequireReusedResults(*db, {job});
  InsertJob(*db, job);
  if (job.notify) WantNotification(*db, job.id, 0, job.owner);
  RecordSubmission(*db, job.owner, request_id, {job.id, 0}, job.created_at);
  db.Commit();
}

std::vector<JobRecord> JobTable::DoneJobsOfScene(const std::string& scene_hash,
                                                 const std::string& scene_toml,
                                                 const std::string& bed_file,
                                                 const std::optional<std::string>& owner,
                                                 int limit) {
  Connection::Reading db = m_connection.Read();
  // (the owner filtered here, not after: another's many copies cannot hide one's own result)
  Statement& s = db->Prepare(std::string("SELECT ") + kListedJobColumns +
                             " FROM jobs WHERE scene_hash = ? AND scene_toml = ? AND bed_file = ? "
                             "AND state = 'done' "
                             "AND (? IS NULL OR owner = ?) ORDER BY reused_from <> 0, id DESC "
                             "LIMIT ?");
  s.Bind(scene_hash, scene_toml, bed_file, owner, owner, limit);
  std::vector<JobRecord> jobs;
  while (s.Step()) jobs.push_back(ReadJobRow(s));
  return jobs;
}

std::optional<Submission> JobTable::FindSubmission(const std::string& owner,
                                                   const std::string& request_id) {
  Connection::Reading db = m_connection.Read();
  Statement& s =
      db->Prepare("SELECT job_id, sweep_id FROM submissions WHERE owner = ? AND request_id = ?");
  s.Bind(owner, request_id);
  if (!s.Step()) return std::nullopt;
  Submission found{s.Int(0), s.Int(1)};
  s.Run();
  return found;
}

std::optional<JobRecord> JobTable::GetJob(std::int64_t id) {
  Connection::Reading db = m_connection.Read();
  Statement& s = db->Prepare(std::string("SELECT ") + kJobColumns + " FROM jobs WHERE id = ?");
  s.Bind(id);
  if (!s.Step()) return std::nullopt;
  JobRecord job = ReadJobRow(s);
  s.Run();
  return job;
}

std::vector<JobRecord> JobTable::ListJobs(const JobFilter& filter, bool* over_max_bytes) {
  Connection::Reading db = m_connection.Read();
  Statement& s =
      db->Prepare(std::string("SELECT ") + (filter.with_scene ? kJobColumns : kListedJobColumns) +
                  " FROM jobs WHERE (? = '' OR state = ?) AND (? = '' OR owner = ?)"
                  " AND (? = 0 OR sweep_id = ?) ORDER BY id DESC LIMIT ?");
  const std::string state = filter.state ? StateName(*filter.state) : "";
  s.Bind(state, state, filter.owner, filter.owner, filter.sweep_id, filter.sweep_id, filter.limit);
  std::vector<JobRecord> jobs;
  std::int64_t bytes = 0;
  if (over_max_bytes) *over_max_bytes = false;
  while (s.Step()) {
    jobs.push_back(ReadJobRow(s));
    bytes += JobRowBytes(jobs.back());
    if (filter.max_bytes > 0 && bytes > filter.max_bytes) {
      if (over_max_bytes) *over_max_bytes = true;
      s.Reset();
      break;
    }
  }
  return jobs;
}

int JobTable::CountQueued() {
  Connection::Reading db = m_connection.Read();
  Statement& s = db->Prepare("SELECT count(*) FROM jobs WHERE state = 'queued'");
  s.Bind();
  const int count = s.Step() ? static_cast<int>(s.Int(0)) : 0;
  s.Run();
  return count;
}

std::vector<JobRecord> JobTable::QueuedJobs() {
  Connection::Reading db = m_connection.Read();
  Statement& s = db->Prepare(std::string("SELECT ") + kJobColumns +
                             " FROM jobs WHERE state = 'queued' ORDER BY id");
  s.Bind();
  std::vector<JobRecord> jobs;
  while (s.Step()) jobs.push_back(ReadJobRow(s));
  return jobs;
}

void JobTable::MarkStarted(std::int64_t id, JobState state, const std::string& host,
                           const std::string& code_version) {
  Connection::Writing db = m_connection.Write();
  db->Prepare(
        "UPDATE jobs SET state = ?, started_at = ?, host = ?, code_version = ?, "
        "attempts = attempts + 1 WHERE id = ?")
      .Bind(StateName(state), report::UtcNow(), host, code_version, id)
      .Run();
  db->Prepare("DELETE FROM series_chunks WHERE job_id = ?").Bind(id).Run();
  db->Prepare("DELETE FROM job_files WHERE job_id = ?").Bind(id).Run();
  db.Commit();
}

void JobTable::SetState(std::int64_t id, JobState state, const std::string& error) {
  Connection::Writing db = m_connection.Write();
  db->Prepare("UPDATE jobs SET state = ?, error = ? WHERE id = ?")
      .Bind(StateName(state), error, id)
      .Run();
  db.Commit();
}

InterruptedJobs JobTable::RequeueInterrupted(const std::string& reason) {
  Connection::Writing db = m_connection.Write();
  Statement& s = db->Prepare(std::string("SELECT ") + kJobColumns +
                             ", crashes FROM jobs WHERE state IN ('preparing_bed', 'running')");
  s.Bind();
  std::vector<std::pair<JobRecord, std::int64_t>> found;
  while (s.Step()) found.push_back({ReadJobRow(s), s.Int(kJobColumnCount)});
  InterruptedJobs out;
  for (const auto& [job, crashes] : found) {
    // The second time: this job may be what brought the daemon down; running it again could
    // bring it down at every start.
    const bool poison = crashes + 1 >= 2;
    const std::string note =
        poison ? "poison job: the daemon stopped twice while running it (a crash, or killed); "
                 "it is not run again (submit it again to retry)"
               : reason;
    db->Prepare("UPDATE jobs SET state = ?, error = ?, crashes = crashes + 1 WHERE id = ?")
        .Bind(poison ? "failed" : "queued", note, job.id)
        .Run();
    db->Prepare("DELETE FROM series_chunks WHERE job_id = ?").Bind(job.id).Run();
    if (poison) {
      db->Prepare("UPDATE jobs SET finished_at = ? WHERE id = ?")
          .Bind(report::UtcNow(), job.id)
          .Run();
      db->Prepare(
            "INSERT OR REPLACE INTO results (job_id, summary_json, sample_count, series, "
            "summary_sha256, series_sha256) VALUES (?, '', 0, zeroblob(0), ?, ?)")
          .Bind(job.id, Sha256Hex(""), Sha256Hex(""))
          .Run();
    }
    db->Prepare("INSERT INTO events (job_id, at, message) VALUES (?, ?, ?)")
        .Bind(job.id, report::UtcNow(), note)
        .Run();
    (poison ? out.poisoned : out.requeued).push_back(job);
  }
  db.Commit();
  return out;
}

std::vector<JobRecord> JobTable::UnfinishedJobs() {
  Connection::Reading db = m_connection.Read();
  Statement& s = db->Prepare(std::string("SELECT ") + kJobColumns +
                             " FROM jobs WHERE state IN ('queued', 'preparing_bed', 'running') "
                             "ORDER BY id");
  s.Bind();
  std::vector<JobRecord> jobs;
  while (s.Step()) jobs.push_back(ReadJobRow(s));
  return jobs;
}

void JobTable::SetSlurmId(const std::vector<std::int64_t>& jobs, std::int64_t slurm_id,
                          std::int64_t array_base) {
  Connection::Writing db = m_connection.Write();
  for (std::int64_t id : jobs) {
    const std::int64_t task = array_base < 0 ? -1 : id - array_base;
    db->Prepare("UPDATE jobs SET slurm_id = ?, slurm_task = ? WHERE id = ?")
        .Bind(slurm_id, task, id)
        .Run();
  }
  db.Commit();
}

void JobTable::SetResultNonce(const std::vector<std::int64_t>& jobs, const std::string& nonce) {
  Connection::Writing db = m_connection.Write();
  for (std::int64_t id : jobs)
    db->Prepare("UPDATE jobs SET result_nonce = ? WHERE id = ?").Bind(nonce, id).Run();
  db.Commit();
}

void JobTable::RequestCancel(std::int64_t id) {
  Connection::Writing db = m_connection.Write();
  db->Prepare("UPDATE jobs SET cancel_requested = 1 WHERE id = ?").Bind(id).Run();
  db.Commit();
}

void JobTable::LogEvent(std::int64_t job_id, const std::string& message) {
  Connection::Writing db = m_connection.Write();
  db->Prepare("INSERT INTO events (job_id, at, message) VALUES (?, ?, ?)")
      .Bind(job_id, report::UtcNow(), message)
      .Run();
  db.Commit();
}

int JobTable::CountQueuedBy(const std::string& owner) {
  Connection::Reading db = m_connection.Read();
  Statement& s = db->Prepare("SELECT count(*) FROM jobs WHERE state = 'queued' AND owner = ?");
  s.Bind(owner);
  const int count = s.Step() ? static_cast<int>(s.Int(0)) : 0;
  s.Run();
  return count;
}

void JobTable::HideTokensInCommandLines(Database& db) {
  // The jobs' command lines, and the summaries' provenance, which repeats them. (Table and
  // column names are this code's own, never a request's.)
  for (const auto& [table, key, column] :
       {std::tuple{"jobs", "id", "command_line"}, {"results", "job_id", "summary_json"}}) {
    std::vector<std::pair<std::int64_t, std::string>> rows;
    Statement& select = db.Prepare(std::string("SELECT ") + key + ", " + column + " FROM " + table +
                                   " WHERE " + column + " LIKE '%--token%'");
    select.Bind();
    while (select.Step()) rows.push_back({select.Int(0), select.Text(1)});
    for (const auto& [id, text] : rows)
      db.Prepare(std::string("UPDATE ") + table + " SET " + column + " = ? WHERE " + key + " = ?")
          .Bind(report::WithoutSecrets(text, ""), id)
          .Run();
  }
}

std::int64_t JobRowBytes(const JobRecord& job) {
  return static_cast<std::int64_t>(job.scene_toml.size() + job.command_line.size() +
                                   job.name.size() + job.error.size() +
                                   nlohmann::json(job.sweep_values).dump().size()) +
         kJobRowOverheadBytes;
}

}  // namespace dembuf::server
