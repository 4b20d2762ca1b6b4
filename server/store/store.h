// The daemon's durable state in one SQLite database, a table by what it keeps: jobs
// (job_table.h), sweeps (sweep_table.h), results: series, summaries and files
// (result_table.h), beds (bed_table.h) and users (user_table.h), all on one connection
// (connection.h) whose Write is the one way to change them: every change that must not be
// seen half-done is one transaction. WAL mode; the schema is migrated by PRAGMA user_version.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "store/bed_table.h"
#include "store/connection.h"
#include "store/job_table.h"
#include "store/notification_table.h"
#include "store/records.h"
#include "store/result_table.h"
#include "store/sweep_table.h"
#include "store/user_table.h"

namespace dembuf::server {

/// The store: its tables, and what spans them (the schema, the check, a user's stored bytes,
/// deleting jobs with everything stored of them).
class Store : private Connection,
              public JobTable,
              public SweepTable,
              public ResultTable,
              public BedTable,
              public UserTable,
              public NotificationTable {
 public:
  /// Opens or creates the database and brings its schema up to date. Throws StoreError with
  /// a clear message for a file that is not a dembuf database, is damaged, or is newer than
  /// this program; such a file is never modified.
  explicit Store(const std::string& path, StoreOptions options = {});
  /// The schema version the database has (older than kSchemaVersion only when read_only).
  int schema_version() const { return m_schema_version; }
  /// The schema version this program writes.
  static int CurrentSchemaVersion();
  /// Whether the database's results carry checksums (its schema version is recent enough).
  bool HasChecksums() const;
  /// Verifies the whole database: SQLite's integrity check, then every stored result against
  /// its checksum (dembufd --check-db).
  CheckReport Check();
  /// The bytes stored for `owner`'s jobs, whatever their state: their records (JobRowBytes)
  /// and their results (summaries, series, result files).
  std::int64_t StoredBytesOf(const std::string& owner);
  /// Deletes these jobs (all ended) and what is stored of them, and every sweep left without
  /// jobs: theirs, and `sweep_id` (0: none; a sweep asked for may have none); the bytes of the
  /// results freed.
  std::int64_t DeleteJobs(const std::vector<std::int64_t>& ids, std::int64_t sweep_id);
  /// This database's daemon id: 8 random hex digits, made once.
  std::string DaemonId();
  using Connection::options;

 private:
  int m_schema_version = 0;
};

}  // namespace dembuf::server
