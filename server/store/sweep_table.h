// The sweeps the daemon keeps, with the jobs they are made of: a table of the store (store.h).
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "store/connection.h"
#include "store/records.h"

namespace dembuf::server {

/// Sweeps: each a record and its jobs (the jobs' rows are JobTable's).
class SweepTable {
 public:
  /// Adds a sweep and its jobs in one transaction; sets their ids. A `request_id` ("" for
  /// none) is recorded with them, for FindSubmission.
  void AddSweep(SweepRecord& sweep, std::vector<JobRecord>& jobs,
                const std::string& request_id = "");
  std::optional<SweepRecord> GetSweep(std::int64_t id);
  std::vector<SweepRecord> ListSweeps(const std::string& owner, int limit);
  std::map<std::string, int> SweepStateCounts(std::int64_t sweep_id);
  /// Bed stages prepared by the sweep's jobs.
  int SweepBedsPrepared(std::int64_t sweep_id);

 protected:
  explicit SweepTable(Connection& connection) : m_connection(connection) {}

 private:
  Connection& m_connection;
};

}  // namespace dembuf::server
