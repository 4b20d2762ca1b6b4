// What jobs leave, each stored with its checksum: the force series (in chunks, as they come),
// the summaries and the result files (snapshots). A table of the store (store.h).
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "store/connection.h"
#include "store/records.h"

namespace dembuf::server {

/// Copies (in the caller's transaction) the done job `from`'s result, its summary, series and
/// files with their checksums, to the job `to`, which is then done, reusing it; false (nothing
/// changed) when `from` is no done job any more.
bool CopyResultIn(Database& db, std::int64_t from, std::int64_t to);
/// The jobs a result may be copied from (CopyResultIn, RequireReusedResults): a WHERE clause on
/// `jobs` binding the job's id twice.
inline constexpr const char* kJobWithStoredResult =
    "id = ? AND state = 'done' AND EXISTS (SELECT 1 FROM results WHERE job_id = ?)";

/// Series, summaries and result files of jobs.
class ResultTable {
 public:
  /// Samples of a running job, from index `first` on, stored in chunks as they come: a series
  /// of any length is stored, and only the unstored part is kept in memory.
  void AppendSeries(std::int64_t id, std::int64_t first, const std::vector<ImpactSample>& samples);
  /// Up to `max` stored samples of a job from index `from` on (fewer at the end).
  std::vector<ImpactSample> ReadSeries(std::int64_t id, std::int64_t from, std::int64_t max);
  /// How many samples of a running job are stored.
  std::int64_t SeriesLength(std::int64_t id);
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

 protected:
  explicit ResultTable(Connection& connection) : m_connection(connection) {}
  /// The upgrades of schema versions 8 and 11: results stored before checksums are taken as
  /// they are; finished jobs' rows get their peak and P from summaries that match theirs.
  static void AddMissingChecksums(Database& db);
  static void AddMissingPeaks(Database& db);
  /// Every stored result against its checksum, into `report` (Store::Check).
  static void CheckResults(Database& db, CheckReport& report);

 private:
  static void AppendSeriesIn(Database& db, std::int64_t id, std::int64_t first,
                             const std::vector<ImpactSample>& samples, std::int64_t chunk_samples);
  static std::vector<ImpactSample> ReadSeriesIn(Database& db, std::int64_t id, std::int64_t from,
                                                std::int64_t max);
  static void PutJobFilesIn(Database& db, std::int64_t id,
                            const std::vector<report::ResultFile>& files);
  static std::string ReadJobFilePieceIn(Database& db, std::int64_t id, const std::string& path,
                                        std::int64_t offset, std::int64_t max);
  static std::optional<std::string> JobFileChecksumIn(Database& db, std::int64_t id,
                                                      const std::string& path);
  /// Throws DamagedData when the job's file does not match its checksum; `read_piece` reads
  /// its bytes from an offset, a piece at a time.
  static void CheckJobFile(std::int64_t id, const std::string& path,
                           const std::optional<std::string>& sha256,
                           const std::function<std::string(std::int64_t offset)>& read_piece);

  Connection& m_connection;
};

}  // namespace dembuf::server
