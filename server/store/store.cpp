#include "store/store.h"

#include <algorithm>
#include <cstdio>
#include <optional>
#include <random>
#include <set>

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
    R"sql(
-- The Slurm executor runs a sweep's jobs as one job array: a job's task in the array that
-- slurm_id names (-1: a job of its own).
ALTER TABLE jobs ADD COLUMN slurm_task INTEGER NOT NULL DEFAULT -1;
)sql",
    R"sql(
-- Notifications owed: a job of its own (job_id) or a sweep (sweep_id) submitted with notify,
-- told to the administrator's chat hook once it has ended (waiting, then sent or failed).
CREATE TABLE notifications (
  id          INTEGER PRIMARY KEY,
  job_id      INTEGER NOT NULL DEFAULT 0,
  sweep_id    INTEGER NOT NULL DEFAULT 0,
  owner       TEXT NOT NULL,
  state       TEXT NOT NULL,
  error       TEXT NOT NULL DEFAULT '',
  created_at  TEXT NOT NULL,
  ended_at    TEXT NOT NULL DEFAULT ''
);
CREATE INDEX notifications_waiting ON notifications(state);
)sql",
    R"sql(
-- A job answered with another's result, not run (the same scene, seed, bed file and engine):
-- that job's id (0: run). Done jobs are looked up by their scene's hash.
ALTER TABLE jobs ADD COLUMN reused_from INTEGER NOT NULL DEFAULT 0;
CREATE INDEX jobs_by_scene ON jobs(scene_hash);
)sql",
    R"sql(
-- Done jobs by scene, bed file and owner: the lookup of a result to reuse reads one owner's
-- done jobs of one scene, however many of them others hold.
CREATE INDEX jobs_done_by_scene ON jobs(scene_hash, bed_file, owner, id) WHERE state = 'done';
)sql",
};
constexpr int kSchemaVersion = sizeof kMigrations / sizeof kMigrations[0];
// The version that added the checksums of summaries, whole series and result files.
constexpr int kChecksumsVersion = 8;  // the eighth migration
// The version that keeps a finished job's peak and P in its row.
constexpr int kPeaksVersion = 11;

}  // namespace

Connection::Connection(const std::string& path, const StoreOptions& options)
    : m_options(options), m_db(std::make_unique<Database>(path, options.read_only)) {
  if (m_options.max_blob_bytes > 0) m_db->SetLengthLimit(m_options.max_blob_bytes);
}

int Store::CurrentSchemaVersion() {
  return kSchemaVersion;
}

bool Store::HasChecksums() const {
  return m_schema_version >= kChecksumsVersion;
}

// (Each table is given the connection, the first base: *this alone would also name the
// table's copy.)
Store::Store(const std::string& path, StoreOptions options) try
    : Connection(path, options),
      JobTable(static_cast<Connection&>(*this)),
      SweepTable(static_cast<Connection&>(*this)),
      ResultTable(static_cast<Connection&>(*this)),
      BedTable(static_cast<Connection&>(*this)),
      UserTable(static_cast<Connection&>(*this)),
      NotificationTable(static_cast<Connection&>(*this)) {
  Reading db = Read();
  // Read-only checks first: a foreign or damaged file is reported, never modified.
  Statement& check = db->Prepare("PRAGMA quick_check");
  check.Bind();
  std::string verdict = check.Step() ? check.Text(0) : "no answer";
  check.Run();
  if (verdict != "ok") throw StoreError("integrity check failed: " + verdict);
  Statement& version = db->Prepare("PRAGMA user_version");
  version.Bind();
  const int have = version.Step() ? static_cast<int>(version.Int(0)) : 0;
  version.Run();
  if (have > kSchemaVersion)
    throw StoreError("its schema version " + std::to_string(have) +
                     " is newer than this dembufd understands (" + std::to_string(kSchemaVersion) +
                     ")");
  if (have == 0) {
    Statement& tables = db->Prepare("SELECT count(*) FROM sqlite_master");
    tables.Bind();
    const auto count = tables.Step() ? tables.Int(0) : 0;
    tables.Run();
    if (count != 0) throw StoreError("it holds tables but is not a dembuf database");
  }
  m_schema_version = have;
  if (options.read_only) return;  // read as it is: no upgrade, no write
  // A database it cannot write (permissions, a read-only file system, a folder where its
  // journal cannot be made) is refused now, not at the first job.
  if (db->ReadOnly())
    throw StoreError("it cannot be written (no write permission, or a read-only file system)");
  try {
    db->Execute("BEGIN IMMEDIATE; COMMIT");
  } catch (const SqliteError& e) {
    throw StoreError(std::string("it cannot be written: ") + e.what());
  }
  db->Execute("PRAGMA journal_mode=WAL; PRAGMA synchronous=NORMAL; PRAGMA foreign_keys=ON");
  for (int v = have; v < kSchemaVersion; ++v) {
    Transaction t(*db);
    db->Execute(kMigrations[v]);
    db->Execute("PRAGMA user_version = " + std::to_string(v + 1));
    m_schema_version = v + 1;
    if (v + 1 == kChecksumsVersion) {
      // Before this version a client could leave its token in a kept command line.
      HideTokensInCommandLines(*db);
      AddMissingChecksums(*db);
    }
    if (v + 1 == kPeaksVersion) AddMissingPeaks(*db);
    t.Commit();
  }
} catch (const StoreError& e) {
  throw StoreError("database " + path + " cannot be used: " + e.what() +
                   "; dembufd leaves it untouched");
} catch (const SqliteError& e) {
  throw StoreError("database " + path + " cannot be used (damaged or not a database?): " +
                   e.what() + "; dembufd leaves it untouched");
}

CheckReport Store::Check() {
  Reading db = Read();
  CheckReport report;
  Statement& integrity = db->Prepare("PRAGMA integrity_check");
  integrity.Bind();
  while (integrity.Step())
    if (integrity.Text(0) != "ok") report.problems.push_back("SQLite: " + integrity.Text(0));
  CheckResults(*db, report);
  return report;
}

std::string Store::DaemonId() {
  auto stored = [](Database& db) -> std::optional<std::string> {
    Statement& read = db.Prepare("SELECT value FROM meta WHERE key = 'daemon_id'");
    read.Bind();
    if (!read.Step()) return std::nullopt;
    std::string id = read.Text(0);
    read.Run();
    return id;
  };
  if (std::optional<std::string> id = stored(*Read())) return *id;  // (a read-only store too)
  Writing db = Write();
  if (std::optional<std::string> id = stored(*db)) return *id;  // made meanwhile
  // Random, so that two daemons (or one whose database was replaced) never share job names.
  std::random_device random;
  char id[16];
  std::snprintf(id, sizeof id, "%08x", random());
  db->Prepare("INSERT INTO meta (key, value) VALUES ('daemon_id', ?)").Bind(std::string(id)).Run();
  db.Commit();
  return id;
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

std::int64_t Store::StoredBytesOf(const std::string& owner) {
  Reading db = Read();
  // (The owner is bound once, as ?1, and used by each subquery.)
  Statement& s = db->Prepare(StoredBytesSql("SELECT id FROM jobs WHERE owner = ?1"));
  s.Bind(owner);
  const std::int64_t bytes = s.Step() ? s.Int(0) : 0;
  s.Run();
  return bytes;
}

std::int64_t Store::DeleteJobs(const std::vector<std::int64_t>& ids, std::int64_t sweep_id) {
  Writing db = Write();
  std::int64_t freed = 0;
  std::set<std::int64_t> sweeps;
  if (sweep_id != 0) sweeps.insert(sweep_id);
  // A deleted job's id is never given again (SQLite would give the largest's to the next
  // job): its Slurm folder, its events and what a user noted of it name it alone.
  if (!ids.empty())
    db->Prepare(
          "INSERT INTO meta (key, value) VALUES ('deleted_job_id_max', ?1) ON CONFLICT(key) DO "
          "UPDATE SET value = max(CAST(value AS INTEGER), ?1)")
        .Bind(*std::max_element(ids.begin(), ids.end()))
        .Run();
  for (const std::int64_t id : ids) {
    Statement& bytes = db->Prepare(StoredBytesSql("SELECT ?1"));
    bytes.Bind(id);
    freed += bytes.Step() ? bytes.Int(0) : 0;
    bytes.Run();
    Statement& sweep = db->Prepare("SELECT sweep_id FROM jobs WHERE id = ?");
    sweep.Bind(id);
    if (sweep.Step() && sweep.Int(0) != 0) sweeps.insert(sweep.Int(0));
    sweep.Run();
    for (const char* table :
         {"series_chunks", "results", "job_files", "bed_preparations", "events", "notifications"})
      db->Prepare(std::string("DELETE FROM ") + table + " WHERE job_id = ?").Bind(id).Run();
    db->Prepare("DELETE FROM submissions WHERE job_id = ?").Bind(id).Run();
    db->Prepare("DELETE FROM jobs WHERE id = ?").Bind(id).Run();
  }
  // A sweep without jobs would stay in the listings, counting nothing.
  for (const std::int64_t sweep : sweeps) {
    Statement& left = db->Prepare("SELECT count(*) FROM jobs WHERE sweep_id = ?");
    left.Bind(sweep);
    const bool empty = left.Step() && left.Int(0) == 0;
    left.Run();
    if (empty) {
      db->Prepare("DELETE FROM submissions WHERE sweep_id = ?").Bind(sweep).Run();
      db->Prepare("DELETE FROM notifications WHERE sweep_id = ?").Bind(sweep).Run();
      db->Prepare("DELETE FROM sweeps WHERE id = ?").Bind(sweep).Run();
    }
  }
  db.Commit();
  return freed;
}

}  // namespace dembuf::server
