#include "jobs/store_recorder.h"

#include "dembuf/study/files/run_output.h"

namespace dembuf::server {

StoreRecorder::StoreRecorder(Store& store, std::int64_t job, LiveJob& live,
                             std::size_t chunk_samples)
    : m_store(store), m_job(job), m_live(live), m_chunk_samples(chunk_samples) {}

void StoreRecorder::Sample(const ImpactSample& sample) {
  m_live.Append(sample);
  if (m_live.Unstored() < m_chunk_samples) return;
  auto [first, samples] = m_live.UnstoredSamples();
  m_store.AppendSeries(m_job, first, samples);
  m_live.Stored(first + static_cast<std::int64_t>(samples.size()));
}

void StoreRecorder::ReferenceSample(const ImpactSample& sample) {
  m_bare.push_back(sample);
}

void StoreRecorder::Files(const std::vector<report::ResultFile>& files) {
  m_store.PutJobFiles(m_job, files);
}

void StoreRecorder::Finished(const ImpactSummary&, const nlohmann::json& summary_json) {
  JobResults results = Results(summary_json.dump(2) + "\n");
  if (!m_bare.empty())
    results.files.push_back({report::run_files::kPlateForceBare, report::SamplesToCsv(m_bare)});
  m_store.FinishJob(m_job, JobState::kDone, "", results);
}

JobResults StoreRecorder::Unfinished() const {
  return Results("");
}

JobResults StoreRecorder::Results(const std::string& summary_json) const {
  auto [first, samples] = m_live.UnstoredSamples();
  return {summary_json, std::move(samples), first, {}};
}

}  // namespace dembuf::server
