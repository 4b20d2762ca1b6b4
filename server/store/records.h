// What the daemon's store keeps, as the rest of the daemon sees it: the records of jobs, sweeps,
// results, bed files and users, the options of the database, and the errors it throws. The
// tables that keep them are store.h's.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "dembuf/study/files/snapshot_report.h"
#include "dembuf/study/impact/impact.h"
#include "dembuf/study/sweep/sweep_plan.h"

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
  int slurm_task = -1;        ///< its task in that job, a job array; -1: not an array's task
  bool cancel_requested = false;
  std::string command_line;  ///< what asked for it, as the client sent it ("" if it did not)
  bool notify = false;  ///< its owner is told when it ends (a job of its own; a sweep's: the sweep)
  /// Filed done with this job's result (the same scene, seed, bed file and engine), not run;
  /// 0: run. Set before it is filed (InsertJob copies the result).
  std::int64_t reused_from = 0;
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
  std::string state;  ///< "submitting" (sbatch's answer not yet had), "submitted", "done",
                      ///< "failed" or "cancelled"
  std::string error;
  std::int64_t job_id = 0;  ///< the job it was first submitted for
};

struct SweepRecord {
  std::int64_t id = 0;
  std::string owner;
  std::string name;
  std::vector<SweepAxis> axes;
  std::string created_at;
  bool notify = false;  ///< its owner is told when its last job ends (as it is filed)
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

/// Results jobs were to be answered with (`reused_from`) went (deleted) between the lookup and
/// the filing: the filing is rolled back, and the submission files those jobs to run. `gone`
/// names every such result of the filing at once (one more filing, not one per result).
class ReusedResultGone : public StoreError {
 public:
  explicit ReusedResultGone(std::vector<std::int64_t> gone)
      : StoreError(std::to_string(gone.size()) + " results to reuse have gone"),
        gone(std::move(gone)) {}
  std::vector<std::int64_t> gone;
};

/// A user's bed files would pass their allowance (BedTable::PutBedFile): the request is refused.
class BedFilesFull : public StoreError {
 public:
  using StoreError::StoreError;
};

/// What Store::Check found: the problems, one line each (none: intact), and what it checked.
struct CheckReport {
  std::vector<std::string> problems;
  std::int64_t summaries = 0, series_chunks = 0, files = 0;
};

}  // namespace dembuf::server
