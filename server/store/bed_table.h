// The beds the daemon keeps: prepared beds (the engine's BedStore), which job prepared which,
// the cluster jobs preparing them (the Slurm executor) and the bed files users sent. A table of
// the store (store.h).
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "dembuf/study/bed/bed.h"
#include "store/connection.h"
#include "store/records.h"

namespace dembuf::server {

/// Prepared beds, their preparations and cluster jobs, and users' bed files.
class BedTable {
 public:
  /// The prepared beds, as a BedStore for the engine's BedCache.
  BedStore& beds() { return m_beds; }
  /// Which job prepared a bed (for "this bed was prepared once").
  void RecordBedPreparation(const std::string& hash, const std::string& stage, std::int64_t job_id);
  std::vector<std::string> BedsPreparedBy(std::int64_t job_id);
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

 protected:
  explicit BedTable(Connection& connection) : m_connection(connection) {}

 private:
  class Beds final : public BedStore {
   public:
    explicit Beds(Connection& connection) : m_connection(connection) {}
    std::optional<PreparedBed> Load(const std::string& hash) override;
    void Save(const PreparedBed& bed) override;
    bool Contains(const std::string& hash) override;

   private:
    Connection& m_connection;
  };
  std::vector<SlurmBedJob> SlurmBedsWhere(const std::string& column, const std::string& value);

  Connection& m_connection;
  std::map<std::pair<std::string, std::string>, BedFile> m_bed_files_read;  ///< under the lock
  Beds m_beds{m_connection};
};

}  // namespace dembuf::server
