// The daemon's durable state in one SQLite database: sweeps, jobs, results (summary and force
// series), prepared beds, and an event log for provenance. WAL mode; every change that must
// not be seen half-done is one transaction; the schema is migrated by PRAGMA user_version.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "dembuf/study/bed/bed.h"
#include "dembuf/study/files/snapshot_report.h"
#include "dembuf/study/impact/impact.h"
#include "dembuf/study/sweep/sweep_plan.h"
#include "sqlite.h"

namespace dembuf::server {

enum class JobState { kQueued, kPreparingBed, kRunning, kDone, kFailed, kCancelled };

/// "queued", "preparing_bed", "running", "done", "failed", "cancelled".
const char* StateName(JobState state);
std::optional<JobState> ParseState(const std::string& name);
inline bool IsFinal(JobState s) {
  return s == JobState::kDone || s == JobState::kFailed || s == JobState::kCancelled;
}

struct JobRecord {
  std::int64_t id = 0;
  std::int64_t sweep_id = 0;  ///< 0: a single job
  int sweep_index = 0;
  std::vector<std::string> sweep_values;
  std::string owner;
  std::string name;
  JobState state = JobState::kQueued;
  std::string error;
  std::string scene_toml;  ///< the complete resolved scene
  std::string scene_hash;
  std::string bed_hash;     ///< "" without beads
  std::string source_hash;  ///< the source bed it is cut from, "" for none
  int attempts = 0;
  std::string created_at;
  std::string started_at;
  std::string finished_at;
  std::string host;
  std::string code_version;
  std::int64_t slurm_id = 0;  ///< the cluster job running it (the Slurm executor); 0: none
  bool cancel_requested = false;
  std::string command_line;  ///< what asked for it, as the client sent it ("" if it did not)
  std::string bed_file;      ///< SHA-256 of the owner's bed file it imports ("" for none)
  std::string result_nonce;  ///< put into its Slurm job's script; its result must carry it
  /// A finished job's peak plate force and P from its summary (nullopt: not known).
  std::optional<double> peak_plate_force_N;
  std::optional<double> P_N;
};

/// The bytes a job's record takes in the database, counted in its owner's stored bytes: its
/// texts (scene, command line, name, error, sweep values) and an allowance for its other
/// columns, index entries and events. A cancelled job's record stays until it is deleted.
inline constexpr std::int64_t kJobRowOverheadBytes = 512;
std::int64_t JobRowBytes(const JobRecord& job);

/// A bed file a user sent to import (PushBed), kept by its owner and the SHA-256 of its bytes.
struct BedFile {
  std::string owner;
  std::string sha256;
  std::string name;                         ///< as its user named it (plain)
  std::shared_ptr<const std::string> data;  ///< shared: every job of a sweep imports it
};

/// A cluster job preparing a bed (the Slurm executor): one per bed hash, shared by every job
/// that needs the bed.
struct SlurmBedJob {
  std::string hash;
  std::string stage;  ///< "source" (only the source bed), or the bed's last: "cut", "friction"
  std::int64_t slurm_id = 0;
  std::string state;  ///< "submitted", "done", "failed" or "cancelled"
  std::string error;
  std::int64_t job_id = 0;  ///< the job it was first submitted for
};

struct SweepRecord {
  std::int64_t id = 0;
  std::string owner;
  std::string name;
  std::vector<SweepAxis> axes;
  std::string created_at;
};

struct JobFilter {
  std::optional<JobState> state;
  std::string owner;  ///< "" for all
  std::int64_t sweep_id = 0;
  int limit = 100;
  bool with_scene = true;      ///< false: scene_toml left empty (a listing shows none)
  std::int64_t max_bytes = 0;  ///< stop past this many bytes of records (JobRowBytes); 0: none
};

/// What a finished (or failed) job leaves: its summary.json, the samples written, and its
/// other files (snapshots).
struct JobResults {
  std::string summary_json;  ///< "" when the job did not finish
  std::vector<ImpactSample> samples;
  /// The index of samples[0] in the job's series: FinishJob stores the samples not yet
  /// appended with AppendSeries (GetResults returns all of them, from 0).
  std::int64_t first_index = 0;
  std::vector<report::ResultFile> files;  ///< stored by FinishJob, beside those of PutJobFiles
};

/// A stored result file of a job.
struct JobFileInfo {
  std::string path;
  std::int64_t size = 0;
};

/// A job of a sweep with its summary, without its series (what a sweep's points are made of).
struct SweepJobResult {
  std::int64_t id = 0;
  int sweep_index = 0;
  std::vector<std::string> sweep_values;
  JobState state = JobState::kQueued;
  std::string error;
  std::string summary_json;  ///< "" until it has finished
};

/// Jobs a daemon found interrupted when it started.
struct InterruptedJobs {
  std::vector<JobRecord> requeued;  ///< queued to run again
  std::vector<JobRecord> poisoned;  ///< interrupted twice: failed, not run again
};

struct StoreOptions {
  /// Samples per stored chunk of a series (4096: 192 kB).
  std::int64_t chunk_samples = 4096;
  /// The longest blob SQLite accepts; 0 keeps SQLite's (1e9 bytes). Tests lower it.
  int max_blob_bytes = 0;
  /// Opened to be read only (dembufd --check-db): nothing is created, upgraded or written,
  /// and a database of an older schema stays as it is (schema_version says which).
  bool read_only = false;
};

/// A holder of an API token.
struct User {
  std::string name;
  bool admin = false;
  std::string token_hash;
};

/// What a request id filed: a job or a sweep (the other id is 0).
struct Submission {
  std::int64_t job_id = 0;
  std::int64_t sweep_id = 0;
};

class StoreError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// A stored result (a summary, a series, a result file) that does not match its checksum or
/// is incomplete: reported as damaged, never served.
class DamagedData : public StoreError {
 public:
  using StoreError::StoreError;
};

/// A user's bed files would pass their room (Store::PutBedFile): the request is refused.
class BedFilesFull : public StoreError {
 public:
  using StoreError::StoreError;
};

/// What Store::Check found: the problems, one line each (none: intact), and what it checked.
struct CheckReport {
  std::vector<std::string> problems;
  std::int64_t summaries = 0, series_chunks = 0, files = 0;
};

class Store {
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

  /// Adds a sweep and its jobs in one transaction; sets their ids. A `request_id` ("" for
  /// none) is recorded with them, for FindSubmission.
  void AddSweep(SweepRecord& sweep, std::vector<JobRecord>& jobs,
                const std::string& request_id = "");
  /// Adds one job; sets its id. A `request_id` as for AddSweep.
  void AddJob(JobRecord& job, const std::string& request_id = "");
  /// The job or sweep `owner` filed with this request id, if any.
  std::optional<Submission> FindSubmission(const std::string& owner, const std::string& request_id);

  std::optional<JobRecord> GetJob(std::int64_t id);
  /// The newest jobs the filter takes; `over_max_bytes`, when given, says whether the listing
  /// stopped at filter.max_bytes.
  std::vector<JobRecord> ListJobs(const JobFilter& filter, bool* over_max_bytes = nullptr);
  std::optional<SweepRecord> GetSweep(std::int64_t id);
  std::vector<SweepRecord> ListSweeps(const std::string& owner, int limit);
  std::map<std::string, int> SweepStateCounts(std::int64_t sweep_id);
  /// Bed stages prepared by the sweep's jobs.
  int SweepBedsPrepared(std::int64_t sweep_id);
  int CountQueued();
  /// Queued jobs, oldest first.
  std::vector<JobRecord> QueuedJobs();

  /// A worker took the job: state, start time, host and code version, one more attempt; the
  /// samples of an earlier attempt are dropped.
  void MarkStarted(std::int64_t id, JobState state, const std::string& host,
                   const std::string& code_version);
  void SetState(std::int64_t id, JobState state, const std::string& error = "");
  /// Samples of a running job, from index `first` on, stored in chunks as they come: a series
  /// of any length is stored, and only the unstored part is kept in memory.
  void AppendSeries(std::int64_t id, std::int64_t first, const std::vector<ImpactSample>& samples);
  /// Up to `max` stored samples of a job from index `from` on (fewer at the end).
  std::vector<ImpactSample> ReadSeries(std::int64_t id, std::int64_t from, std::int64_t max);
  /// The end of a job, with its results (the samples not yet appended), in one transaction.
  void FinishJob(std::int64_t id, JobState state, const std::string& error,
                 const JobResults& results);
  /// A finished job's summary and whole series; throws StoreError for a damaged series.
  std::optional<JobResults> GetResults(std::int64_t id);
  /// A finished job's summary.json, without its series; "" when it has none; DamagedData when
  /// it does not match its checksum.
  std::string Summary(std::int64_t id);
  /// Up to `max` samples of a finished job's series from index `from` on, stored in chunks or
  /// (by a daemon before chunks) whole; throws StoreError for a damaged series.
  std::vector<ImpactSample> ReadResultSeries(std::int64_t id, std::int64_t from, std::int64_t max);
  /// How many samples a finished job's series has (0 without results).
  std::int64_t ResultSeriesLength(std::int64_t id);
  /// The jobs of a sweep in sweep order, with their summaries.
  std::vector<SweepJobResult> SweepResults(std::int64_t sweep_id);
  /// Stores result files of a running job (a snapshot as it is taken); a job's files are
  /// removed when it starts again.
  void PutJobFiles(std::int64_t id, const std::vector<report::ResultFile>& files);
  /// The result files of a job (snapshots), by path.
  std::vector<JobFileInfo> JobFiles(std::int64_t id);
  /// Up to `max` bytes of a job's result file from byte `offset` on ("" past its end). A read
  /// from offset 0 checks the whole file against its checksum first (DamagedData).
  std::string ReadJobFile(std::int64_t id, const std::string& path, std::int64_t offset,
                          std::int64_t max);

  /// Verifies the whole database: SQLite's integrity check, then every stored result against
  /// its checksum (dembufd --check-db).
  CheckReport Check();

  /// At start: jobs left preparing or running by a daemon that died go back to the queue,
  /// with a note, unless this is the second time (they may be what killed it): those fail.
  InterruptedJobs RequeueInterrupted(const std::string& reason);

  /// Which job prepared a bed (for "this bed was prepared once").
  void RecordBedPreparation(const std::string& hash, const std::string& stage, std::int64_t job_id);
  std::vector<std::string> BedsPreparedBy(std::int64_t job_id);

  /// Users: a token's hash names its user. SetUser adds one or replaces its token.
  void SetUser(const std::string& name, const std::string& token_hash, bool admin);
  std::vector<User> ListUsers();
  bool RemoveUser(const std::string& name);
  bool AnyUsers();
  int CountQueuedBy(const std::string& owner);
  /// The bytes stored for `owner`'s jobs, whatever their state: their records (JobRowBytes)
  /// and their results (summaries, series, result files).
  std::int64_t StoredBytesOf(const std::string& owner);
  /// Deletes these jobs (all ended) and what is stored of them, and every sweep left without
  /// jobs: theirs, and `sweep_id` (0: none; a sweep asked for may have none); the bytes of the
  /// results freed.
  std::int64_t DeleteJobs(const std::vector<std::int64_t>& ids, std::int64_t sweep_id);

  /// This database's daemon id: 8 random hex digits, made once.
  std::string DaemonId();
  /// Jobs queued, preparing or running, oldest first.
  std::vector<JobRecord> UnfinishedJobs();
  void SetSlurmId(std::int64_t id, std::int64_t slurm_id);
  /// Keeps the nonce given to the job's Slurm job (the Slurm executor), before it is submitted.
  void SetResultNonce(std::int64_t id, const std::string& nonce);
  /// Notes that the job's user asked to cancel it.
  void RequestCancel(std::int64_t id);
  /// How many samples of a running job are stored.
  std::int64_t SeriesLength(std::int64_t id);
  std::optional<SlurmBedJob> GetSlurmBed(const std::string& hash);
  std::vector<SlurmBedJob> SlurmBedsInState(const std::string& state);
  void PutSlurmBed(const SlurmBedJob& bed);

  /// Keeps a user's bed file; false when they had sent the same bytes before (kept as then).
  /// A user's files hold at most `max_bytes_per_owner`: their oldest that no unfinished job
  /// imports are removed to make room, and BedFilesFull is thrown when that is not enough.
  bool PutBedFile(const BedFile& file, std::int64_t max_bytes_per_owner);
  /// The owner's bed file of that SHA-256, or nothing. Throws DamagedData when its bytes no
  /// longer match it. The last few read are kept in memory, checked: the jobs of a sweep on
  /// one file read it once, not once a job.
  std::optional<BedFile> GetBedFile(const std::string& owner, const std::string& sha256);

  /// Appends to the provenance log.
  void LogEvent(std::int64_t job_id, const std::string& message);

  const StoreOptions& options() const { return m_options; }

  /// The prepared beds, as a BedStore for the engine's BedCache.
  BedStore& beds() { return m_beds; }

 private:
  class Beds final : public BedStore {
   public:
    explicit Beds(Store& store) : m_store(store) {}
    std::optional<PreparedBed> Load(const std::string& hash) override;
    void Save(const PreparedBed& bed) override;
    bool Contains(const std::string& hash) override;

   private:
    Store& m_store;
  };

  JobRecord ReadJob(Statement& s);
  /// The bed jobs whose `column` ("hash" or "state": a name of ours, never a user's) is `value`.
  std::vector<SlurmBedJob> SlurmBedsWhere(const std::string& column, const std::string& value);
  void InsertJobLocked(JobRecord& job);
  void PutJobFilesLocked(std::int64_t id, const std::vector<report::ResultFile>& files);
  std::string ReadJobFilePieceLocked(std::int64_t id, const std::string& path, std::int64_t offset,
                                     std::int64_t max);
  /// A result file's stored checksum ("" for none), or nothing when there is no such file.
  std::optional<std::string> JobFileChecksumLocked(std::int64_t id, const std::string& path);
  /// SHA-256 of a stored file read in pieces; `locked`: the caller holds the store's lock,
  /// else it is taken for one piece at a time.
  std::string JobFileSha256(std::int64_t id, const std::string& path, bool locked);
  /// Throws DamagedData when the stored file does not match its checksum.
  void CheckJobFile(std::int64_t id, const std::string& path, bool locked);
  /// Checksums for the rows stored before the database had them (its upgrade).
  void AddMissingChecksumsLocked();
  /// Done jobs of before the peaks version get their peak and P from intact summaries.
  void AddMissingPeaksLocked();
  /// Any --token value in the command lines (and summaries) kept before version 8, hidden.
  void HideTokensInCommandLinesLocked();
  void AppendSeriesLocked(std::int64_t id, std::int64_t first,
                          const std::vector<ImpactSample>& samples);
  std::vector<ImpactSample> ReadSeriesLocked(std::int64_t id, std::int64_t from, std::int64_t max);

  StoreOptions m_options;
  int m_schema_version = 0;
  /// Bed files read and checked lately, by owner and SHA-256 (kBedFilesKept at most).
  std::map<std::pair<std::string, std::string>, BedFile> m_bed_files_read;
  std::mutex m_mutex;  // one connection, used by one thread at a time
  std::unique_ptr<Database> m_db;
  Beds m_beds{*this};
};

}  // namespace dembuf::server
