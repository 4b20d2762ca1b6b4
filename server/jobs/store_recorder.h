// A daemon job's run recorded into the store (run_job.h's other recorder besides the folder):
// samples go to the job's live view, which watchers read, and to its series in chunks; the
// files of snapshots and frames are stored as they come; the summary, the series' last samples
// and the bare-plate series go in the write that marks the job done.
#pragma once

#include <cstdint>
#include <vector>

#include "dembuf/study/run/run_job.h"
#include "jobs/live_job.h"
#include "store/store.h"

namespace dembuf::server {

class StoreRecorder final : public RunRecorder {
 public:
  /// `chunk_samples`: the samples kept in memory before they are appended to the series.
  StoreRecorder(Store& store, std::int64_t job, LiveJob& live, std::size_t chunk_samples);

  void Sample(const ImpactSample& sample) override;
  void ReferenceSample(const ImpactSample& sample) override;
  void Files(const std::vector<report::ResultFile>& files) override;
  /// Stores the results and marks the job done.
  void Finished(const ImpactSummary& summary, const nlohmann::json& summary_json) override;

  /// The samples not stored yet, for a job that ends otherwise (failed, cancelled).
  JobResults Unfinished() const;

 private:
  JobResults Results(const std::string& summary_json) const;

  Store& m_store;
  std::int64_t m_job;
  LiveJob& m_live;
  std::size_t m_chunk_samples;
  std::vector<ImpactSample> m_bare;  ///< the bare-plate impact: a few hundred samples
};

}  // namespace dembuf::server
