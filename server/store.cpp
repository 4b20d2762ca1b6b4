#include "store.h"

#include <cstdio>
#include <cstring>
#include <ctime>
#include <nlohmann/json.hpp>
#include <random>
#include <set>
#include <tuple>

#include "dembuf/study/files/provenance.h"
#include "dembuf/study/files/run_output.h"
#include "fault_injection.h"

namespace dembuf::server {

namespace {

// Schema migrations: entry k brings user_version k to k + 1. Never edit a released entry;
// append a new one.
const char* const kMigrations[] = {
    R"sql(
CREATE TABLE sweeps (
  id          INTEGER PRIMARY KEY,
  owner       TEXT NOT NULL,
  name        TEXT NOT NULL,
  axes_json   TEXT NOT NULL,
  created_at  TEXT NOT NULL
);
CREATE TABLE jobs (
  id                 INTEGER PRIMARY KEY,
  sweep_id           INTEGER REFERENCES sweeps(id),
  sweep_index        INTEGER NOT NULL DEFAULT 0,
  sweep_values_json  TEXT NOT NULL DEFAULT '[]',
  owner              TEXT NOT NULL,
  name               TEXT NOT NULL,
  state              TEXT NOT NULL,
  error              TEXT NOT NULL DEFAULT '',
  scene_toml         TEXT NOT NULL,
  scene_hash         TEXT NOT NULL,
  bed_hash           TEXT NOT NULL,
  source_hash        TEXT NOT NULL,
  attempts           INTEGER NOT NULL DEFAULT 0,
  created_at         TEXT NOT NULL,
  started_at         TEXT NOT NULL DEFAULT '',
  finished_at        TEXT NOT NULL DEFAULT '',
  host               TEXT NOT NULL DEFAULT '',
  code_version       TEXT NOT NULL DEFAULT ''
);
CREATE INDEX jobs_by_state ON jobs(state);
CREATE INDEX jobs_by_sweep ON jobs(sweep_id);
CREATE INDEX jobs_by_owner ON jobs(owner);
-- series: the samples as rows of six little-endian doubles, in the columns of plate_force.csv
CREATE TABLE results (
  job_id        INTEGER PRIMARY KEY REFERENCES jobs(id),
  summary_json  TEXT NOT NULL,
  sample_count  INTEGER NOT NULL,
  series        BLOB NOT NULL
);
CREATE TABLE beds (
  hash         TEXT PRIMARY KEY,
  stage        TEXT NOT NULL,
  beads        INTEGER NOT NULL,
  data         BLOB NOT NULL,
  created_at   TEXT NOT NULL
);
CREATE TABLE bed_preparations (
  hash         TEXT NOT NULL,
  stage        TEXT NOT NULL,
  job_id       INTEGER NOT NULL REFERENCES jobs(id),
  at           TEXT NOT NULL
);
CREATE INDEX bed_preparations_by_job ON bed_preparations(job_id);
CREATE TABLE events (
  id       INTEGER PRIMARY KEY,
  job_id   INTEGER NOT NULL,
  at       TEXT NOT NULL,
  message  TEXT NOT NULL
);
)sql",
    R"sql(
CREATE TABLE users (
  name        TEXT PRIMARY KEY,
  token_hash  TEXT NOT NULL UNIQUE,
  admin       INTEGER NOT NULL DEFAULT 0,
  created_at  TEXT NOT NULL
);
)sql",
    R"sql(
-- A job's series in chunks, written while it runs, each with the SHA-256 of its bytes (rows
-- of six little-endian doubles, as results.series). results.series stays empty for jobs
-- stored this way; it holds the whole series of jobs finished before.
CREATE TABLE series_chunks (
  job_id        INTEGER NOT NULL REFERENCES jobs(id),
  first_index   INTEGER NOT NULL,
  sample_count  INTEGER NOT NULL,
  data          BLOB NOT NULL,
  sha256        TEXT NOT NULL,
  PRIMARY KEY (job_id, first_index)
);
-- How often a daemon died while running the job (kill -9, power cut, or the job itself).
ALTER TABLE jobs ADD COLUMN crashes INTEGER NOT NULL DEFAULT 0;
)sql",
    R"sql(
-- The Slurm executor: the cluster job that runs a job (0: none), and whether its user asked
-- to cancel it (so that its end in Slurm reads as cancelled, not failed).
ALTER TABLE jobs ADD COLUMN slurm_id INTEGER NOT NULL DEFAULT 0;
ALTER TABLE jobs ADD COLUMN cancel_requested INTEGER NOT NULL DEFAULT 0;
-- The cluster jobs that prepare beds, one per bed hash, shared by every job that needs it.
CREATE TABLE slurm_beds (
  hash          TEXT PRIMARY KEY,
  stage         TEXT NOT NULL,
  slurm_id      INTEGER NOT NULL,
  state         TEXT NOT NULL,
  error         TEXT NOT NULL DEFAULT '',
  job_id        INTEGER NOT NULL,  -- the job it was first submitted for
  submitted_at  TEXT NOT NULL
);
-- Facts about this database: its daemon's id (in the names of its cluster jobs).
CREATE TABLE meta (
  key    TEXT PRIMARY KEY,
  value  TEXT NOT NULL
);
)sql",
    R"sql(
-- The files a job leaves besides its summary and series (the snapshots of E5), stored with it
-- when it ends; a path is relative to the job's folder ("snapshots/peak/contacts.csv").
CREATE TABLE job_files (
  job_id  INTEGER NOT NULL REFERENCES jobs(id),
  path    TEXT NOT NULL,
  data    BLOB NOT NULL,
  PRIMARY KEY (job_id, path)
);
)sql",
    R"sql(
-- Provenance: the command that asked for the job (the client's, as it sent it).
ALTER TABLE jobs ADD COLUMN command_line TEXT NOT NULL DEFAULT '';
)sql",
    R"sql(
-- Submissions by the id their client chose: a retry after a lost reply is answered with the
-- job or sweep filed the first time, in the same transaction as it was filed.
CREATE TABLE submissions (
  owner       TEXT NOT NULL,
  request_id  TEXT NOT NULL,
  job_id      INTEGER NOT NULL DEFAULT 0,
  sweep_id    INTEGER NOT NULL DEFAULT 0,
  created_at  TEXT NOT NULL,
  PRIMARY KEY (owner, request_id)
);
)sql",
    R"sql(
-- Checksums (SHA-256, hex) of what the series chunks did not cover: a summary, a series
-- stored whole (before chunks) and a result file, checked on every read. Rows stored before
-- get theirs when the daemon upgrades the database (Store::AddMissingChecksums).
ALTER TABLE results ADD COLUMN summary_sha256 TEXT NOT NULL DEFAULT '';
ALTER TABLE results ADD COLUMN series_sha256 TEXT NOT NULL DEFAULT '';
ALTER TABLE job_files ADD COLUMN sha256 TEXT NOT NULL DEFAULT '';
)sql",
    R"sql(
-- Bed files users sent (PushBed, kind "file"), by owner and SHA-256 of their bytes, and the
-- one a job imports ('' for none).
CREATE TABLE bed_files (
  owner       TEXT NOT NULL,
  sha256      TEXT NOT NULL,
  name        TEXT NOT NULL,
  data        BLOB NOT NULL,
  created_at  TEXT NOT NULL,
  PRIMARY KEY (owner, sha256)
);
ALTER TABLE jobs ADD COLUMN bed_file TEXT NOT NULL DEFAULT '';
)sql",
    R"sql(
-- The Slurm executor's proof that a run's result is the run's it started: a random nonce
-- given to its Slurm job, which the run writes into its summary.json and failure.json.
ALTER TABLE jobs ADD COLUMN result_nonce TEXT NOT NULL DEFAULT '';
)sql",
    R"sql(
-- A finished job's peak plate force and P, from its summary as it ends, so that a listing
-- shows them without reading summaries (NULL: not known). Jobs that ended before get them
-- at the upgrade (Store::AddMissingPeaksLocked), from summaries that match their checksums.
ALTER TABLE jobs ADD COLUMN peak_plate_force_N REAL;
ALTER TABLE jobs ADD COLUMN P_N REAL;
)sql",
};
constexpr int kSchemaVersion = sizeof kMigrations / sizeof kMigrations[0];
// The version that added the checksums of summaries, whole series and result files.
constexpr int kChecksumsVersion = 8;  // the eighth migration
// The version that keeps a finished job's peak and P in its row.
constexpr int kPeaksVersion = 11;

nlohmann::json AxesToJson(const std::vector<SweepAxis>& axes) {
  nlohmann::json out = nlohmann::json::array();
  for (const SweepAxis& a : axes) out.push_back({{"field", a.field}, {"values", a.values}});
  return out;
}

std::vector<SweepAxis> AxesFromJson(const std::string& text) {
  std::vector<SweepAxis> axes;
  for (const auto& a : nlohmann::json::parse(text))
    axes.push_back({a["field"].get<std::string>(), a["values"].get<std::vector<std::string>>()});
  return axes;
}

// Throws DamagedData naming `what` unless `data` has the checksum `sha256` (an empty one is
// no checksum: a row whose checksum was cleared is not taken on trust).
void CheckSum(const std::string& data, const std::string& sha256, const std::string& what) {
  if (sha256.empty() || report::Sha256Hex(data) != sha256)
    throw DamagedData(what + " is damaged: it does not match its checksum");
}

constexpr std::int64_t kHashPieceBytes = 1 << 20;

// A done job's peak plate force and P, as its row keeps them: numbers of its summary, else
// not known.
std::pair<std::optional<double>, std::optional<double>> PeakAndP(const std::string& summary_json) {
  const nlohmann::json summary = nlohmann::json::parse(summary_json, nullptr, false);
  auto number = [&](const char* key) -> std::optional<double> {
    if (!summary.is_object() || !summary.contains(key) || !summary[key].is_number())
      return std::nullopt;
    return summary[key].get<double>();
  };
  return {number("peak_plate_force_N"), number("P_N")};
}

const char* const kJobColumns =
    "id, IFNULL(sweep_id, 0), sweep_index, sweep_values_json, owner, name, state, error, "
    "scene_toml, scene_hash, bed_hash, source_hash, attempts, created_at, started_at, "
    "finished_at, host, code_version, slurm_id, cancel_requested, bed_file, result_nonce, "
    "peak_plate_force_N, P_N, command_line";
// The same for a listing, which shows no scene: its text is not read ('' in its place).
const char* const kListedJobColumns =
    "id, IFNULL(sweep_id, 0), sweep_index, sweep_values_json, owner, name, state, error, "
    "'', scene_hash, bed_hash, source_hash, attempts, created_at, started_at, "
    "finished_at, host, code_version, slurm_id, cancel_requested, bed_file, result_nonce, "
    "peak_plate_force_N, P_N, command_line";
// How many kJobColumns names: a column selected after them has this index.
constexpr int kJobColumnCount = 25;

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

int Store::CurrentSchemaVersion() {
  return kSchemaVersion;
}

bool Store::HasChecksums() const {
  return m_schema_version >= kChecksumsVersion;
}

Store::Store(const std::string& path, StoreOptions options) : m_options(options) {
  try {
    m_db = std::make_unique<Database>(path, m_options.read_only);
    if (m_options.max_blob_bytes > 0) m_db->SetLengthLimit(m_options.max_blob_bytes);
    // Read-only checks first: a foreign or damaged file is reported, never modified.
    Statement& check = m_db->Prepare("PRAGMA quick_check");
    check.Bind();
    std::string verdict = check.Step() ? check.Text(0) : "no answer";
    check.Run();
    if (verdict != "ok") throw StoreError("integrity check failed: " + verdict);
    Statement& version = m_db->Prepare("PRAGMA user_version");
    version.Bind();
    const int have = version.Step() ? static_cast<int>(version.Int(0)) : 0;
    version.Run();
    if (have > kSchemaVersion)
      throw StoreError("its schema version " + std::to_string(have) +
                       " is newer than this dembufd understands (" +
                       std::to_string(kSchemaVersion) + ")");
    if (have == 0) {
      Statement& tables = m_db->Prepare("SELECT count(*) FROM sqlite_master");
      tables.Bind();
      const auto count = tables.Step() ? tables.Int(0) : 0;
      tables.Run();
      if (count != 0) throw StoreError("it holds tables but is not a dembuf database");
    }
    m_schema_version = have;
    if (m_options.read_only) return;  // read as it is: no upgrade, no write
    // A database it cannot write (permissions, a read-only file system, a folder where its
    // journal cannot be made) is refused now, not at the first job.
    if (m_db->ReadOnly())
      throw StoreError("it cannot be written (no write permission, or a read-only file system)");
    try {
      m_db->Execute("BEGIN IMMEDIATE; COMMIT");
    } catch (const SqliteError& e) {
      throw StoreError(std::string("it cannot be written: ") + e.what());
    }
    m_db->Execute("PRAGMA journal_mode=WAL; PRAGMA synchronous=NORMAL; PRAGMA foreign_keys=ON");
    for (int v = have; v < kSchemaVersion; ++v) {
      Transaction t(*m_db);
      m_db->Execute(kMigrations[v]);
      m_db->Execute("PRAGMA user_version = " + std::to_string(v + 1));
      m_schema_version = v + 1;
      if (v + 1 == kChecksumsVersion) {
        // Before this version a client could leave its token in a kept command line.
        HideTokensInCommandLinesLocked();
        AddMissingChecksumsLocked();
      }
      if (v + 1 == kPeaksVersion) AddMissingPeaksLocked();
      t.Commit();
    }
  } catch (const StoreError& e) {
    throw StoreError("database " + path + " cannot be used: " + e.what() +
                     "; dembufd leaves it untouched");
  } catch (const SqliteError& e) {
    throw StoreError("database " + path + " cannot be used (damaged or not a database?): " +
                     e.what() + "; dembufd leaves it untouched");
  }
}

JobRecord Store::ReadJob(Statement& s) {
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
  j.command_line = s.Text(kJobColumnCount - 1);
  return j;
}

void Store::InsertJobLocked(JobRecord& job) {
  job.created_at = report::UtcNow();
  Statement& s = m_db->Prepare(
      "INSERT INTO jobs (sweep_id, sweep_index, sweep_values_json, owner, name, state, "
      "scene_toml, scene_hash, bed_hash, source_hash, created_at, command_line, bed_file) "
      "VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)");
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
  job.id = m_db->LastInsertId();
}

void Store::AddSweep(SweepRecord& sweep, std::vector<JobRecord>& jobs,
                     const std::string& request_id) {
  std::lock_guard lock(m_mutex);
  Transaction t(*m_db);
  sweep.created_at = report::UtcNow();
  m_db->Prepare("INSERT INTO sweeps (owner, name, axes_json, created_at) VALUES (?, ?, ?, ?)")
      .Bind(sweep.owner, sweep.name, AxesToJson(sweep.axes).dump(), sweep.created_at)
      .Run();
  sweep.id = m_db->LastInsertId();
  for (JobRecord& job : jobs) {
    job.sweep_id = sweep.id;
    InsertJobLocked(job);
  }
  if (!request_id.empty())
    m_db->Prepare(
            "INSERT INTO submissions (owner, request_id, sweep_id, created_at) "
            "VALUES (?, ?, ?, ?)")
        .Bind(sweep.owner, request_id, sweep.id, sweep.created_at)
        .Run();
  t.Commit();
}

void Store::AddJob(JobRecord& job, const std::string& request_id) {
  std::lock_guard lock(m_mutex);
  Transaction t(*m_db);
  InsertJobLocked(job);
  if (!request_id.empty())
    m_db->Prepare(
            "INSERT INTO submissions (owner, request_id, job_id, created_at) "
            "VALUES (?, ?, ?, ?)")
        .Bind(job.owner, request_id, job.id, job.created_at)
        .Run();
  t.Commit();
}

std::optional<Submission> Store::FindSubmission(const std::string& owner,
                                                const std::string& request_id) {
  std::lock_guard lock(m_mutex);
  Statement& s =
      m_db->Prepare("SELECT job_id, sweep_id FROM submissions WHERE owner = ? AND request_id = ?");
  s.Bind(owner, request_id);
  if (!s.Step()) return std::nullopt;
  Submission found{s.Int(0), s.Int(1)};
  s.Run();
  return found;
}

std::optional<JobRecord> Store::GetJob(std::int64_t id) {
  std::lock_guard lock(m_mutex);
  Statement& s = m_db->Prepare(std::string("SELECT ") + kJobColumns + " FROM jobs WHERE id = ?");
  s.Bind(id);
  if (!s.Step()) return std::nullopt;
  JobRecord job = ReadJob(s);
  s.Run();
  return job;
}

std::vector<JobRecord> Store::ListJobs(const JobFilter& filter, bool* over_max_bytes) {
  std::lock_guard lock(m_mutex);
  Statement& s =
      m_db->Prepare(std::string("SELECT ") + (filter.with_scene ? kJobColumns : kListedJobColumns) +
                    " FROM jobs WHERE (? = '' OR state = ?) AND (? = '' OR owner = ?)"
                    " AND (? = 0 OR sweep_id = ?) ORDER BY id DESC LIMIT ?");
  const std::string state = filter.state ? StateName(*filter.state) : "";
  s.Bind(state, state, filter.owner, filter.owner, filter.sweep_id, filter.sweep_id, filter.limit);
  std::vector<JobRecord> jobs;
  std::int64_t bytes = 0;
  if (over_max_bytes) *over_max_bytes = false;
  while (s.Step()) {
    jobs.push_back(ReadJob(s));
    bytes += JobRowBytes(jobs.back());
    if (filter.max_bytes > 0 && bytes > filter.max_bytes) {
      if (over_max_bytes) *over_max_bytes = true;
      s.Reset();
      break;
    }
  }
  return jobs;
}

std::optional<SweepRecord> Store::GetSweep(std::int64_t id) {
  std::lock_guard lock(m_mutex);
  Statement& s =
      m_db->Prepare("SELECT id, owner, name, axes_json, created_at FROM sweeps WHERE id = ?");
  s.Bind(id);
  if (!s.Step()) return std::nullopt;
  SweepRecord sweep{s.Int(0), s.Text(1), s.Text(2), AxesFromJson(s.Text(3)), s.Text(4)};
  s.Run();
  return sweep;
}

std::vector<SweepRecord> Store::ListSweeps(const std::string& owner, int limit) {
  std::lock_guard lock(m_mutex);
  Statement& s = m_db->Prepare(
      "SELECT id, owner, name, axes_json, created_at FROM sweeps WHERE (? = '' OR owner = ?) "
      "ORDER BY id DESC LIMIT ?");
  s.Bind(owner, owner, limit);
  std::vector<SweepRecord> sweeps;
  while (s.Step())
    sweeps.push_back({s.Int(0), s.Text(1), s.Text(2), AxesFromJson(s.Text(3)), s.Text(4)});
  return sweeps;
}

std::map<std::string, int> Store::SweepStateCounts(std::int64_t sweep_id) {
  std::lock_guard lock(m_mutex);
  Statement& s =
      m_db->Prepare("SELECT state, count(*) FROM jobs WHERE sweep_id = ? GROUP BY state");
  s.Bind(sweep_id);
  std::map<std::string, int> counts;
  while (s.Step()) counts[s.Text(0)] = static_cast<int>(s.Int(1));
  return counts;
}

int Store::SweepBedsPrepared(std::int64_t sweep_id) {
  std::lock_guard lock(m_mutex);
  Statement& s = m_db->Prepare(
      "SELECT count(*) FROM bed_preparations WHERE job_id IN "
      "(SELECT id FROM jobs WHERE sweep_id = ?)");
  s.Bind(sweep_id);
  const int count = s.Step() ? static_cast<int>(s.Int(0)) : 0;
  s.Run();
  return count;
}

int Store::CountQueued() {
  std::lock_guard lock(m_mutex);
  Statement& s = m_db->Prepare("SELECT count(*) FROM jobs WHERE state = 'queued'");
  s.Bind();
  const int count = s.Step() ? static_cast<int>(s.Int(0)) : 0;
  s.Run();
  return count;
}

std::vector<JobRecord> Store::QueuedJobs() {
  std::lock_guard lock(m_mutex);
  Statement& s = m_db->Prepare(std::string("SELECT ") + kJobColumns +
                               " FROM jobs WHERE state = 'queued' ORDER BY id");
  s.Bind();
  std::vector<JobRecord> jobs;
  while (s.Step()) jobs.push_back(ReadJob(s));
  return jobs;
}

void Store::MarkStarted(std::int64_t id, JobState state, const std::string& host,
                        const std::string& code_version) {
  std::lock_guard lock(m_mutex);
  Transaction t(*m_db);
  m_db->Prepare(
          "UPDATE jobs SET state = ?, started_at = ?, host = ?, code_version = ?, "
          "attempts = attempts + 1 WHERE id = ?")
      .Bind(StateName(state), report::UtcNow(), host, code_version, id)
      .Run();
  m_db->Prepare("DELETE FROM series_chunks WHERE job_id = ?").Bind(id).Run();
  m_db->Prepare("DELETE FROM job_files WHERE job_id = ?").Bind(id).Run();
  t.Commit();
}

void Store::SetState(std::int64_t id, JobState state, const std::string& error) {
  std::lock_guard lock(m_mutex);
  m_db->Prepare("UPDATE jobs SET state = ?, error = ? WHERE id = ?")
      .Bind(StateName(state), error, id)
      .Run();
}

void Store::AppendSeriesLocked(std::int64_t id, std::int64_t first,
                               const std::vector<ImpactSample>& samples) {
  const auto chunk = static_cast<std::size_t>(std::max<std::int64_t>(m_options.chunk_samples, 1));
  for (std::size_t begin = 0; begin < samples.size(); begin += chunk) {
    const std::size_t end = std::min(samples.size(), begin + chunk);
    const std::string bytes = report::PackSamples({samples.begin() + begin, samples.begin() + end});
    m_db->Prepare(
            "INSERT OR REPLACE INTO series_chunks (job_id, first_index, sample_count, data, "
            "sha256) VALUES (?, ?, ?, ?, ?)")
        .Bind(id, first + static_cast<std::int64_t>(begin), static_cast<std::int64_t>(end - begin),
              Statement::Bytes{bytes}, report::Sha256Hex(bytes))
        .Run();
  }
}

void Store::AppendSeries(std::int64_t id, std::int64_t first,
                         const std::vector<ImpactSample>& samples) {
  std::lock_guard lock(m_mutex);
  Transaction t(*m_db);
  AppendSeriesLocked(id, first, samples);
  t.Commit();
}

std::vector<ImpactSample> Store::ReadSeriesLocked(std::int64_t id, std::int64_t from,
                                                  std::int64_t max) {
  Statement& s = m_db->Prepare(
      "SELECT first_index, sample_count, data, sha256 FROM series_chunks "
      "WHERE job_id = ? AND first_index + sample_count > ? ORDER BY first_index");
  s.Bind(id, from);
  std::vector<ImpactSample> out;
  std::int64_t next = -1;  // where the next chunk must start
  auto damaged = [&](const std::string& why) {
    s.Bind();  // ends the statement before throwing
    return DamagedData("the series of job " + std::to_string(id) + " is damaged: " + why);
  };
  while (static_cast<std::int64_t>(out.size()) < max && s.Step()) {
    const std::int64_t first = s.Int(0), count = s.Int(1);
    const std::string bytes = s.Blob(2);
    if (next >= 0 && first != next)
      throw damaged("samples " + std::to_string(next) + " to " + std::to_string(first - 1) +
                    " are missing");
    if (first > from && next < 0)
      throw damaged("samples " + std::to_string(from) + " to " + std::to_string(first - 1) +
                    " are missing");
    if (report::Sha256Hex(bytes) != s.Text(3) ||
        bytes.size() != static_cast<std::size_t>(count) * report::kPackedSampleBytes)
      throw damaged("the chunk from sample " + std::to_string(first) +
                    " does not match its checksum");
    const std::vector<ImpactSample> chunk = report::UnpackSamples(bytes);
    for (std::int64_t k = std::max<std::int64_t>(from - first, 0);
         k < count && static_cast<std::int64_t>(out.size()) < max; ++k)
      out.push_back(chunk[k]);
    next = first + count;
  }
  s.Bind();  // reset: the statement may have stopped early
  return out;
}

std::vector<ImpactSample> Store::ReadSeries(std::int64_t id, std::int64_t from, std::int64_t max) {
  std::lock_guard lock(m_mutex);
  return ReadSeriesLocked(id, from, max);
}

void Store::FinishJob(std::int64_t id, JobState state, const std::string& error,
                      const JobResults& results) {
  FaultError("store-error-at-result-write");  // a failing database (the worker test)
  std::lock_guard lock(m_mutex);
  Transaction t(*m_db);
  AppendSeriesLocked(id, results.first_index, results.samples);
  m_db->Prepare(
          "INSERT OR REPLACE INTO results (job_id, summary_json, sample_count, series, "
          "summary_sha256, series_sha256) VALUES (?, ?, ?, zeroblob(0), ?, ?)")
      .Bind(id, results.summary_json,
            results.first_index + static_cast<std::int64_t>(results.samples.size()),
            report::Sha256Hex(results.summary_json), report::Sha256Hex(""))
      .Run();
  PutJobFilesLocked(id, results.files);
  FaultPoint("kill-during-result-write");  // the series is written, the job not yet done
  // Its peak and P, for listings.
  const auto [peak, p] = state == JobState::kDone
                             ? PeakAndP(results.summary_json)
                             : std::pair<std::optional<double>, std::optional<double>>();
  m_db->Prepare(
          "UPDATE jobs SET state = ?, error = ?, finished_at = ?, peak_plate_force_N = ?, "
          "P_N = ? WHERE id = ?")
      .Bind(StateName(state), error, report::UtcNow(), peak, p, id)
      .Run();
  t.Commit();
}

void Store::PutJobFiles(std::int64_t id, const std::vector<report::ResultFile>& files) {
  std::lock_guard lock(m_mutex);
  Transaction t(*m_db);
  PutJobFilesLocked(id, files);
  t.Commit();
}

void Store::PutJobFilesLocked(std::int64_t id, const std::vector<report::ResultFile>& files) {
  for (const report::ResultFile& file : files)
    m_db->Prepare(
            "INSERT OR REPLACE INTO job_files (job_id, path, data, sha256) VALUES (?, ?, ?, ?)")
        .Bind(id, file.path, Database::AsBlob(file.data), report::Sha256Hex(file.data))
        .Run();
}

std::string Store::ReadJobFilePieceLocked(std::int64_t id, const std::string& path,
                                          std::int64_t offset, std::int64_t max) {
  // substr counts bytes of a blob from 1.
  Statement& s =
      m_db->Prepare("SELECT substr(data, ? + 1, ?) FROM job_files WHERE job_id = ? AND path = ?");
  s.Bind(offset, max, id, path);
  std::string data = s.Step() ? s.Blob(0) : std::string();
  s.Run();
  return data;
}

std::optional<std::string> Store::JobFileChecksumLocked(std::int64_t id, const std::string& path) {
  Statement& s = m_db->Prepare("SELECT sha256 FROM job_files WHERE job_id = ? AND path = ?");
  s.Bind(id, path);
  if (!s.Step()) return std::nullopt;
  std::string sha = s.Text(0);
  s.Run();
  return sha;
}

std::string Store::JobFileSha256(std::int64_t id, const std::string& path, bool locked) {
  // A caller without the lock takes it for one piece at a time: a large file is checked
  // without holding the store for every other request meanwhile.
  report::Sha256Stream hash;
  for (std::int64_t offset = 0;; offset += kHashPieceBytes) {
    std::unique_lock lock(m_mutex, std::defer_lock);
    if (!locked) lock.lock();
    const std::string piece = ReadJobFilePieceLocked(id, path, offset, kHashPieceBytes);
    if (lock.owns_lock()) lock.unlock();
    hash.Add(piece);
    if (static_cast<std::int64_t>(piece.size()) < kHashPieceBytes) break;
  }
  return hash.Hex();
}

void Store::CheckJobFile(std::int64_t id, const std::string& path, bool locked) {
  std::optional<std::string> sha;
  if (locked) {
    sha = JobFileChecksumLocked(id, path);
  } else {
    std::lock_guard lock(m_mutex);
    sha = JobFileChecksumLocked(id, path);
  }
  if (!sha) return;  // no such file: nothing to serve
  if (sha->empty() || JobFileSha256(id, path, locked) != *sha)
    throw DamagedData("the result file " + path + " of job " + std::to_string(id) +
                      " is damaged: it does not match its checksum");
}

void Store::HideTokensInCommandLinesLocked() {
  // The jobs' command lines, and the summaries' provenance, which repeats them. (Table and
  // column names are this code's own, never a request's.)
  for (const auto& [table, key, column] :
       {std::tuple{"jobs", "id", "command_line"}, {"results", "job_id", "summary_json"}}) {
    std::vector<std::pair<std::int64_t, std::string>> rows;
    Statement& select = m_db->Prepare(std::string("SELECT ") + key + ", " + column + " FROM " +
                                      table + " WHERE " + column + " LIKE '%--token%'");
    select.Bind();
    while (select.Step()) rows.push_back({select.Int(0), select.Text(1)});
    for (const auto& [id, text] : rows)
      m_db->Prepare(std::string("UPDATE ") + table + " SET " + column + " = ? WHERE " + key +
                    " = ?")
          .Bind(report::WithoutSecrets(text, ""), id)
          .Run();
  }
}

void Store::AddMissingChecksumsLocked() {
  // Results stored before checksums: taken as they are at the upgrade.
  std::vector<std::int64_t> ids;
  Statement& results = m_db->Prepare("SELECT job_id FROM results WHERE summary_sha256 = ''");
  results.Bind();
  while (results.Step()) ids.push_back(results.Int(0));
  for (std::int64_t id : ids) {
    Statement& row = m_db->Prepare("SELECT summary_json, series FROM results WHERE job_id = ?");
    row.Bind(id);
    row.Step();
    const std::string summary = row.Text(0), series = row.Blob(1);
    row.Run();
    m_db->Prepare("UPDATE results SET summary_sha256 = ?, series_sha256 = ? WHERE job_id = ?")
        .Bind(report::Sha256Hex(summary), report::Sha256Hex(series), id)
        .Run();
  }
  std::vector<std::pair<std::int64_t, std::string>> files;
  Statement& list = m_db->Prepare("SELECT job_id, path FROM job_files WHERE sha256 = ''");
  list.Bind();
  while (list.Step()) files.push_back({list.Int(0), list.Text(1)});
  for (const auto& [id, path] : files)
    m_db->Prepare("UPDATE job_files SET sha256 = ? WHERE job_id = ? AND path = ?")
        .Bind(JobFileSha256(id, path, /*locked=*/true), id, path)
        .Run();
}

void Store::AddMissingPeaksLocked() {
  // Only from a summary that matches its checksum: a damaged one leaves them not known.
  std::vector<std::pair<std::int64_t, std::string>> done;
  Statement& s = m_db->Prepare(
      "SELECT j.id, r.summary_json, r.summary_sha256 FROM jobs j JOIN results r "
      "ON r.job_id = j.id WHERE j.state = 'done'");
  s.Bind();
  while (s.Step()) {
    const std::string summary = s.Text(1);
    try {
      CheckSum(summary, s.Text(2), "the summary of job " + std::to_string(s.Int(0)));
      done.push_back({s.Int(0), summary});
    } catch (const DamagedData&) {
    }
  }
  for (const auto& [id, summary] : done) {
    const auto [peak, p] = PeakAndP(summary);
    m_db->Prepare("UPDATE jobs SET peak_plate_force_N = ?, P_N = ? WHERE id = ?")
        .Bind(peak, p, id)
        .Run();
  }
}

CheckReport Store::Check() {
  std::lock_guard lock(m_mutex);
  CheckReport report;
  Statement& integrity = m_db->Prepare("PRAGMA integrity_check");
  integrity.Bind();
  while (integrity.Step())
    if (integrity.Text(0) != "ok") report.problems.push_back("SQLite: " + integrity.Text(0));
  std::vector<std::int64_t> ids;
  Statement& results = m_db->Prepare("SELECT job_id FROM results ORDER BY job_id");
  results.Bind();
  while (results.Step()) ids.push_back(results.Int(0));
  for (std::int64_t id : ids) {
    Statement& row = m_db->Prepare(
        "SELECT summary_json, summary_sha256, series, series_sha256, sample_count FROM results "
        "WHERE job_id = ?");
    row.Bind(id);
    row.Step();
    const std::string summary = row.Text(0), summary_sha = row.Text(1), series = row.Blob(2),
                      series_sha = row.Text(3);
    const std::int64_t count = row.Int(4);
    row.Run();
    ++report.summaries;
    try {
      CheckSum(summary, summary_sha, "the summary of job " + std::to_string(id));
      CheckSum(series, series_sha, "the series of job " + std::to_string(id));
      if (series.empty()) {
        // Every chunk, read as FetchSeries reads it: checksums, order, the count.
        std::int64_t read = 0;
        for (std::int64_t from = 0; from < count; from += read) {
          read = static_cast<std::int64_t>(ReadSeriesLocked(id, from, 1 << 16).size());
          if (read == 0) break;
        }
        Statement& chunks = m_db->Prepare(
            "SELECT count(*), IFNULL(sum(sample_count), 0) FROM series_chunks WHERE job_id = ?");
        chunks.Bind(id);
        chunks.Step();
        report.series_chunks += chunks.Int(0);
        const std::int64_t stored = chunks.Int(1);
        chunks.Run();
        if (stored != count)
          throw DamagedData("the series of job " + std::to_string(id) +
                            " is damaged: " + std::to_string(stored) + " of its " +
                            std::to_string(count) + " samples are stored");
      }
    } catch (const DamagedData& e) {
      report.problems.push_back(e.what());
    }
  }
  std::vector<std::pair<std::int64_t, std::string>> files;
  Statement& list = m_db->Prepare("SELECT job_id, path FROM job_files ORDER BY job_id, path");
  list.Bind();
  while (list.Step()) files.push_back({list.Int(0), list.Text(1)});
  for (const auto& [id, path] : files) {
    ++report.files;
    try {
      CheckJobFile(id, path, /*locked=*/true);
    } catch (const DamagedData& e) {
      report.problems.push_back(e.what());
    }
  }
  return report;
}

std::vector<JobFileInfo> Store::JobFiles(std::int64_t id) {
  std::lock_guard lock(m_mutex);
  Statement& s =
      m_db->Prepare("SELECT path, length(data) FROM job_files WHERE job_id = ? ORDER BY path");
  s.Bind(id);
  std::vector<JobFileInfo> files;
  while (s.Step()) files.push_back({s.Text(0), s.Int(1)});
  return files;
}

std::string Store::ReadJobFile(std::int64_t id, const std::string& path, std::int64_t offset,
                               std::int64_t max) {
  if (offset == 0) CheckJobFile(id, path, /*locked=*/false);
  std::lock_guard lock(m_mutex);
  return ReadJobFilePieceLocked(id, path, offset, max);
}

std::optional<JobResults> Store::GetResults(std::int64_t id) {
  std::lock_guard lock(m_mutex);
  Statement& s = m_db->Prepare(
      "SELECT summary_json, sample_count, series, summary_sha256, series_sha256 FROM results "
      "WHERE job_id = ?");
  s.Bind(id);
  if (!s.Step()) return std::nullopt;
  JobResults results{s.Text(0), {}, 0, {}};
  const std::int64_t count = s.Int(1);
  const std::string legacy = s.Blob(2);  // a whole series, from before chunks
  const std::string summary_sha = s.Text(3), series_sha = s.Text(4);
  s.Run();
  CheckSum(results.summary_json, summary_sha, "the summary of job " + std::to_string(id));
  CheckSum(legacy, series_sha, "the series of job " + std::to_string(id));
  if (!legacy.empty()) {
    results.samples = report::UnpackSamples(legacy);
    return results;
  }
  results.samples = ReadSeriesLocked(id, 0, count);
  if (static_cast<std::int64_t>(results.samples.size()) != count)
    throw DamagedData("the series of job " + std::to_string(id) +
                      " is damaged: " + std::to_string(results.samples.size()) + " of its " +
                      std::to_string(count) + " samples are stored");
  return results;
}

std::string Store::Summary(std::int64_t id) {
  std::lock_guard lock(m_mutex);
  Statement& s = m_db->Prepare("SELECT summary_json, summary_sha256 FROM results WHERE job_id = ?");
  s.Bind(id);
  if (!s.Step()) return "";
  std::string summary = s.Text(0);
  const std::string sha = s.Text(1);
  s.Run();
  CheckSum(summary, sha, "the summary of job " + std::to_string(id));
  return summary;
}

std::vector<ImpactSample> Store::ReadResultSeries(std::int64_t id, std::int64_t from,
                                                  std::int64_t max) {
  std::lock_guard lock(m_mutex);
  Statement& s = m_db->Prepare("SELECT length(series) FROM results WHERE job_id = ?");
  s.Bind(id);
  const bool whole = s.Step() && s.Int(0) > 0;
  s.Run();
  if (!whole) return ReadSeriesLocked(id, from, max);
  // A series stored whole, by a daemon from before chunks: read it all, keep the part asked.
  Statement& blob = m_db->Prepare("SELECT series, series_sha256 FROM results WHERE job_id = ?");
  blob.Bind(id);
  blob.Step();
  const std::string bytes = blob.Blob(0), sha = blob.Text(1);
  blob.Run();
  CheckSum(bytes, sha, "the series of job " + std::to_string(id));
  const std::vector<ImpactSample> all = report::UnpackSamples(bytes);
  const auto size = static_cast<std::int64_t>(all.size());
  const std::int64_t begin = std::clamp<std::int64_t>(from, 0, size);
  const std::int64_t end =
      std::clamp<std::int64_t>(begin + std::max<std::int64_t>(max, 0), 0, size);
  return {all.begin() + begin, all.begin() + end};
}

std::int64_t Store::ResultSeriesLength(std::int64_t id) {
  std::lock_guard lock(m_mutex);
  Statement& s = m_db->Prepare("SELECT sample_count FROM results WHERE job_id = ?");
  s.Bind(id);
  const std::int64_t count = s.Step() ? s.Int(0) : 0;
  s.Run();
  return count;
}

std::vector<SweepJobResult> Store::SweepResults(std::int64_t sweep_id) {
  std::lock_guard lock(m_mutex);
  Statement& s = m_db->Prepare(
      "SELECT j.id, j.sweep_index, j.sweep_values_json, j.state, j.error, "
      "IFNULL(r.summary_json, ''), IFNULL(r.summary_sha256, ?) FROM jobs j "
      "LEFT JOIN results r ON r.job_id = j.id WHERE j.sweep_id = ? ORDER BY j.sweep_index, j.id");
  s.Bind(report::Sha256Hex(""), sweep_id);
  std::vector<SweepJobResult> jobs;
  while (s.Step()) {
    SweepJobResult job;
    job.id = s.Int(0);
    job.sweep_index = static_cast<int>(s.Int(1));
    job.sweep_values = nlohmann::json::parse(s.Text(2)).get<std::vector<std::string>>();
    job.state = ParseState(s.Text(3)).value_or(JobState::kFailed);
    job.error = s.Text(4);
    job.summary_json = s.Text(5);
    // A damaged summary is left out, the job's point with it, and says so.
    try {
      CheckSum(job.summary_json, s.Text(6), "the summary of job " + std::to_string(job.id));
    } catch (const DamagedData& e) {
      job.summary_json.clear();
      job.error = e.what();
    }
    jobs.push_back(std::move(job));
  }
  return jobs;
}

InterruptedJobs Store::RequeueInterrupted(const std::string& reason) {
  std::lock_guard lock(m_mutex);
  Transaction t(*m_db);
  Statement& s = m_db->Prepare(std::string("SELECT ") + kJobColumns +
                               ", crashes FROM jobs WHERE state IN ('preparing_bed', 'running')");
  s.Bind();
  std::vector<std::pair<JobRecord, std::int64_t>> found;
  while (s.Step()) found.push_back({ReadJob(s), s.Int(kJobColumnCount)});
  InterruptedJobs out;
  for (const auto& [job, crashes] : found) {
    // The second time: this job may be what brought the daemon down; running it again could
    // bring it down at every start.
    const bool poison = crashes + 1 >= 2;
    const std::string note =
        poison ? "poison job: the daemon stopped twice while running it (a crash, or killed); "
                 "it is not run again (submit it again to retry)"
               : reason;
    m_db->Prepare("UPDATE jobs SET state = ?, error = ?, crashes = crashes + 1 WHERE id = ?")
        .Bind(poison ? "failed" : "queued", note, job.id)
        .Run();
    m_db->Prepare("DELETE FROM series_chunks WHERE job_id = ?").Bind(job.id).Run();
    if (poison) {
      m_db->Prepare("UPDATE jobs SET finished_at = ? WHERE id = ?")
          .Bind(report::UtcNow(), job.id)
          .Run();
      m_db->Prepare(
              "INSERT OR REPLACE INTO results (job_id, summary_json, sample_count, series, "
              "summary_sha256, series_sha256) VALUES (?, '', 0, zeroblob(0), ?, ?)")
          .Bind(job.id, report::Sha256Hex(""), report::Sha256Hex(""))
          .Run();
    }
    m_db->Prepare("INSERT INTO events (job_id, at, message) VALUES (?, ?, ?)")
        .Bind(job.id, report::UtcNow(), note)
        .Run();
    (poison ? out.poisoned : out.requeued).push_back(job);
  }
  t.Commit();
  return out;
}

void Store::RecordBedPreparation(const std::string& hash, const std::string& stage,
                                 std::int64_t job_id) {
  std::lock_guard lock(m_mutex);
  m_db->Prepare("INSERT INTO bed_preparations (hash, stage, job_id, at) VALUES (?, ?, ?, ?)")
      .Bind(hash, stage, job_id, report::UtcNow())
      .Run();
}

std::vector<std::string> Store::BedsPreparedBy(std::int64_t job_id) {
  std::lock_guard lock(m_mutex);
  Statement& s =
      m_db->Prepare("SELECT stage, hash FROM bed_preparations WHERE job_id = ? ORDER BY rowid");
  s.Bind(job_id);
  std::vector<std::string> beds;
  while (s.Step()) beds.push_back(s.Text(0) + " " + s.Text(1));
  return beds;
}

std::string Store::DaemonId() {
  std::lock_guard lock(m_mutex);
  Statement& read = m_db->Prepare("SELECT value FROM meta WHERE key = 'daemon_id'");
  read.Bind();
  if (read.Step()) {
    std::string id = read.Text(0);
    read.Run();
    return id;
  }
  read.Run();
  // Random, so that two daemons (or one whose database was replaced) never share job names.
  std::random_device random;
  char id[16];
  std::snprintf(id, sizeof id, "%08x", random());
  m_db->Prepare("INSERT INTO meta (key, value) VALUES ('daemon_id', ?)")
      .Bind(std::string(id))
      .Run();
  return id;
}

std::vector<JobRecord> Store::UnfinishedJobs() {
  std::lock_guard lock(m_mutex);
  Statement& s = m_db->Prepare(std::string("SELECT ") + kJobColumns +
                               " FROM jobs WHERE state IN ('queued', 'preparing_bed', 'running') "
                               "ORDER BY id");
  s.Bind();
  std::vector<JobRecord> jobs;
  while (s.Step()) jobs.push_back(ReadJob(s));
  return jobs;
}

void Store::SetSlurmId(std::int64_t id, std::int64_t slurm_id) {
  std::lock_guard lock(m_mutex);
  m_db->Prepare("UPDATE jobs SET slurm_id = ? WHERE id = ?").Bind(slurm_id, id).Run();
}

void Store::SetResultNonce(std::int64_t id, const std::string& nonce) {
  std::lock_guard lock(m_mutex);
  m_db->Prepare("UPDATE jobs SET result_nonce = ? WHERE id = ?").Bind(nonce, id).Run();
}

void Store::RequestCancel(std::int64_t id) {
  std::lock_guard lock(m_mutex);
  m_db->Prepare("UPDATE jobs SET cancel_requested = 1 WHERE id = ?").Bind(id).Run();
}

std::int64_t Store::SeriesLength(std::int64_t id) {
  std::lock_guard lock(m_mutex);
  Statement& s = m_db->Prepare(
      "SELECT IFNULL(MAX(first_index + sample_count), 0) FROM series_chunks WHERE job_id = ?");
  s.Bind(id);
  s.Step();
  const std::int64_t length = s.Int(0);
  s.Run();
  return length;
}

std::vector<SlurmBedJob> Store::SlurmBedsWhere(const std::string& column,
                                               const std::string& value) {
  std::lock_guard lock(m_mutex);
  Statement& s = m_db->Prepare(
      "SELECT hash, stage, slurm_id, state, error, job_id FROM slurm_beds "
      "WHERE " +
      column + " = ?");
  s.Bind(value);
  std::vector<SlurmBedJob> beds;
  while (s.Step()) beds.push_back({s.Text(0), s.Text(1), s.Int(2), s.Text(3), s.Text(4), s.Int(5)});
  return beds;
}

std::optional<SlurmBedJob> Store::GetSlurmBed(const std::string& hash) {
  std::vector<SlurmBedJob> beds = SlurmBedsWhere("hash", hash);
  if (beds.empty()) return std::nullopt;
  return beds.front();
}

std::vector<SlurmBedJob> Store::SlurmBedsInState(const std::string& state) {
  return SlurmBedsWhere("state", state);
}

void Store::PutSlurmBed(const SlurmBedJob& bed) {
  std::lock_guard lock(m_mutex);
  m_db->Prepare(
          "INSERT OR REPLACE INTO slurm_beds (hash, stage, slurm_id, state, error, job_id, "
          "submitted_at) VALUES (?, ?, ?, ?, ?, ?, ?)")
      .Bind(bed.hash, bed.stage, bed.slurm_id, bed.state, bed.error, bed.job_id, report::UtcNow())
      .Run();
}

void Store::LogEvent(std::int64_t job_id, const std::string& message) {
  std::lock_guard lock(m_mutex);
  m_db->Prepare("INSERT INTO events (job_id, at, message) VALUES (?, ?, ?)")
      .Bind(job_id, report::UtcNow(), message)
      .Run();
}

void Store::SetUser(const std::string& name, const std::string& token_hash, bool admin) {
  std::lock_guard lock(m_mutex);
  m_db->Prepare(
          "INSERT INTO users (name, token_hash, admin, created_at) VALUES (?, ?, ?, ?) "
          "ON CONFLICT(name) DO UPDATE SET token_hash = excluded.token_hash, "
          "admin = excluded.admin")
      .Bind(name, token_hash, admin ? 1 : 0, report::UtcNow())
      .Run();
}

std::vector<User> Store::ListUsers() {
  std::lock_guard lock(m_mutex);
  Statement& s = m_db->Prepare("SELECT name, admin, token_hash FROM users ORDER BY name");
  s.Bind();
  std::vector<User> users;
  while (s.Step()) users.push_back({s.Text(0), s.Int(1) != 0, s.Text(2)});
  return users;
}

bool Store::RemoveUser(const std::string& name) {
  std::lock_guard lock(m_mutex);
  m_db->Prepare("DELETE FROM users WHERE name = ?").Bind(name).Run();
  return m_db->Changes() > 0;
}

bool Store::AnyUsers() {
  std::lock_guard lock(m_mutex);
  Statement& s = m_db->Prepare("SELECT count(*) FROM users");
  s.Bind();
  const bool any = s.Step() && s.Int(0) > 0;
  s.Run();
  return any;
}

int Store::CountQueuedBy(const std::string& owner) {
  std::lock_guard lock(m_mutex);
  Statement& s = m_db->Prepare("SELECT count(*) FROM jobs WHERE state = 'queued' AND owner = ?");
  s.Bind(owner);
  const int count = s.Step() ? static_cast<int>(s.Int(0)) : 0;
  s.Run();
  return count;
}

namespace {

// The bytes stored of the jobs a condition selects (`jobs`: "... FROM jobs WHERE ..." giving
// their ids), in one place for the quota and for deleting.
std::string StoredBytesSql(const std::string& jobs) {
  // (The records' part is JobRowBytes's, in SQL: bytes, not characters.)
  auto bytes = [](const char* column) {
    return std::string("length(CAST(") + column + " AS BLOB)) + ";
  };
  return "SELECT (SELECT IFNULL(SUM(" + bytes("scene_toml") + bytes("command_line") +
         bytes("name") + bytes("error") + bytes("sweep_values_json") +
         std::to_string(kJobRowOverheadBytes) + "), 0) FROM jobs WHERE id IN (" + jobs +
         ")) + (SELECT IFNULL(SUM(length(summary_json) + length(series)), 0) FROM results "
         "WHERE job_id IN (" +
         jobs +
         ")) + (SELECT IFNULL(SUM(length(data)), 0) FROM "
         "series_chunks WHERE job_id IN (" +
         jobs +
         ")) + (SELECT IFNULL(SUM(length(data)), 0) "
         "FROM job_files WHERE job_id IN (" +
         jobs + "))";
}

}  // namespace

std::int64_t JobRowBytes(const JobRecord& job) {
  return static_cast<std::int64_t>(job.scene_toml.size() + job.command_line.size() +
                                   job.name.size() + job.error.size() +
                                   nlohmann::json(job.sweep_values).dump().size()) +
         kJobRowOverheadBytes;
}

std::int64_t Store::StoredBytesOf(const std::string& owner) {
  std::lock_guard lock(m_mutex);
  // (The owner is bound once, as ?1, and used by each subquery.)
  Statement& s = m_db->Prepare(StoredBytesSql("SELECT id FROM jobs WHERE owner = ?1"));
  s.Bind(owner);
  const std::int64_t bytes = s.Step() ? s.Int(0) : 0;
  s.Run();
  return bytes;
}

std::int64_t Store::DeleteJobs(const std::vector<std::int64_t>& ids, std::int64_t sweep_id) {
  std::lock_guard lock(m_mutex);
  Transaction t(*m_db);
  std::int64_t freed = 0;
  std::set<std::int64_t> sweeps;
  if (sweep_id != 0) sweeps.insert(sweep_id);
  for (const std::int64_t id : ids) {
    Statement& bytes = m_db->Prepare(StoredBytesSql("SELECT ?1"));
    bytes.Bind(id);
    freed += bytes.Step() ? bytes.Int(0) : 0;
    bytes.Run();
    Statement& sweep = m_db->Prepare("SELECT sweep_id FROM jobs WHERE id = ?");
    sweep.Bind(id);
    if (sweep.Step() && sweep.Int(0) != 0) sweeps.insert(sweep.Int(0));
    sweep.Run();
    for (const char* table :
         {"series_chunks", "results", "job_files", "bed_preparations", "events"})
      m_db->Prepare(std::string("DELETE FROM ") + table + " WHERE job_id = ?").Bind(id).Run();
    m_db->Prepare("DELETE FROM submissions WHERE job_id = ?").Bind(id).Run();
    m_db->Prepare("DELETE FROM jobs WHERE id = ?").Bind(id).Run();
  }
  // A sweep without jobs would stay in the listings, counting nothing.
  for (const std::int64_t sweep : sweeps) {
    Statement& left = m_db->Prepare("SELECT count(*) FROM jobs WHERE sweep_id = ?");
    left.Bind(sweep);
    const bool empty = left.Step() && left.Int(0) == 0;
    left.Run();
    if (empty) {
      m_db->Prepare("DELETE FROM submissions WHERE sweep_id = ?").Bind(sweep).Run();
      m_db->Prepare("DELETE FROM sweeps WHERE id = ?").Bind(sweep).Run();
    }
  }
  t.Commit();
  return freed;
}

std::optional<PreparedBed> Store::Beds::Load(const std::string& hash) {
  std::lock_guard lock(m_store.m_mutex);
  Statement& s = m_store.m_db->Prepare("SELECT data FROM beds WHERE hash = ?");
  s.Bind(hash);
  if (!s.Step()) return std::nullopt;
  const std::string bytes = s.Blob(0);
  s.Run();
  return ParseBed(bytes, "bed " + hash + " in the database");
}

void Store::Beds::Save(const PreparedBed& bed) {
  const std::string bytes = SerializeBed(bed);
  std::lock_guard lock(m_store.m_mutex);
  m_store.m_db
      ->Prepare(
          "INSERT OR REPLACE INTO beds (hash, stage, beads, data, created_at) "
          "VALUES (?, ?, ?, ?, ?)")
      .Bind(bed.hash, bed.stage, static_cast<std::int64_t>(bed.beads.size()),
            Statement::Bytes{bytes}, report::UtcNow())
      .Run();
}

bool Store::PutBedFile(const BedFile& file, std::int64_t max_bytes_per_owner) {
  std::lock_guard lock(m_mutex);
  Statement& known = m_db->Prepare("SELECT 1 FROM bed_files WHERE owner = ? AND sha256 = ?");
  known.Bind(file.owner, file.sha256);
  const bool had_it = known.Step();
  known.Run();
  if (had_it) return false;
  // Room for it: the owner's oldest files that no unfinished job imports make way, unless even
  // all of them would not make enough (then nothing is removed).
  Statement& files = m_db->Prepare(
      "SELECT sha256, LENGTH(data), sha256 IN (SELECT bed_file FROM jobs WHERE owner = ? AND "
      "state IN ('queued', 'preparing_bed', 'running')) FROM bed_files WHERE owner = ? "
      "ORDER BY created_at, rowid");  // (rowid: the order of one second's files)
  files.Bind(file.owner, file.owner);
  std::int64_t stored = 0, waited_for = 0;
  std::vector<std::pair<std::string, std::int64_t>> removable;  // oldest first
  while (files.Step()) {
    stored += files.Int(1);
    if (files.Int(2) != 0)
      waited_for += files.Int(1);
    else
      removable.emplace_back(files.Text(0), files.Int(1));
  }
  files.Run();
  const auto size = static_cast<std::int64_t>(file.data->size());
  if (waited_for + size > max_bytes_per_owner)
    throw BedFilesFull(file.owner + "'s bed files waiting for their jobs hold " +
                       std::to_string(waited_for) + " bytes; with these " + std::to_string(size) +
                       " they would pass " + std::to_string(max_bytes_per_owner) +
                       " (4 x max_bed_push_mb): wait for those jobs to end");
  for (const auto& [sha256, bytes] : removable) {
    if (stored + size <= max_bytes_per_owner) break;
    m_db->Prepare("DELETE FROM bed_files WHERE owner = ? AND sha256 = ?")
        .Bind(file.owner, sha256)
        .Run();
    m_bed_files_read.erase({file.owner, sha256});
    stored -= bytes;
  }
  Statement& s = m_db->Prepare(
      "INSERT INTO bed_files (owner, sha256, name, data, created_at) VALUES (?, ?, ?, ?, ?)");
  s.Bind(file.owner, file.sha256, file.name, Statement::Bytes{*file.data}, report::UtcNow());
  s.Run();
  return true;
}

std::optional<BedFile> Store::GetBedFile(const std::string& owner, const std::string& sha256) {
  constexpr std::size_t kBedFilesKept = 4;
  std::lock_guard lock(m_mutex);
  if (const auto kept = m_bed_files_read.find({owner, sha256}); kept != m_bed_files_read.end())
    return kept->second;
  Statement& s = m_db->Prepare("SELECT name, data FROM bed_files WHERE owner = ? AND sha256 = ?");
  s.Bind(owner, sha256);
  if (!s.Step()) return std::nullopt;
  BedFile file{owner, sha256, s.Text(0), std::make_shared<const std::string>(s.Blob(1))};
  s.Run();
  if (report::Sha256Hex(*file.data) != sha256)
    throw DamagedData("bed file " + sha256 + " is damaged: it does not match its checksum");
  if (m_bed_files_read.size() >= kBedFilesKept) m_bed_files_read.erase(m_bed_files_read.begin());
  m_bed_files_read.emplace(std::pair{owner, sha256}, file);
  return file;
}

bool Store::Beds::Contains(const std::string& hash) {
  std::lock_guard lock(m_store.m_mutex);
  Statement& s = m_store.m_db->Prepare("SELECT 1 FROM beds WHERE hash = ?");
  s.Bind(hash);
  const bool found = s.Step();
  s.Run();
  return found;
}

}  // namespace dembuf::server
