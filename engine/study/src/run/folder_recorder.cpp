#include "dembuf/study/run/folder_recorder.h"

#include "dembuf/study/files/own_files.h"
#include "dembuf/study/files/provenance.h"
#include "dembuf/study/files/run_output.h"

namespace dembuf {

FolderRecorder::FolderRecorder(std::filesystem::path dir, const Scene& scene,
                               std::filesystem::path samples_stream, std::string result_nonce)
    : m_dir(std::move(dir)),
      m_stream_path(std::move(samples_stream)),
      m_result_nonce(std::move(result_nonce)) {
  std::filesystem::create_directories(m_dir);
  report::CloseToOthersWriting(m_dir);  // a sweep keeps only such runs (own_files.h)
  // What ran, in a file that runs it again.
  report::WriteFileAtomically(m_dir / report::run_files::kScene, report::SceneText(scene));
}

void FolderRecorder::Sample(const ImpactSample& sample) {
  if (!m_csv) {
    m_csv.emplace(m_dir / report::run_files::kPlateForce);
    if (!m_stream_path.empty()) m_stream.emplace(m_stream_path);
  }
  m_csv->Write(sample);
  if (m_stream) m_stream->Write(sample);
}

void FolderRecorder::ReferenceSample(const ImpactSample& sample) {
  m_bare.push_back(sample);
}

void FolderRecorder::Files(const std::vector<report::ResultFile>& files) {
  report::WriteResultFiles(files, m_dir);
}

void FolderRecorder::Finished(const ImpactSummary&, const nlohmann::json& summary_json) {
  if (!m_csv)
    m_csv.emplace(m_dir / report::run_files::kPlateForce);  // a run without samples: the header
  m_csv->Commit();
  if (!m_bare.empty())
    report::WriteFileAtomically(m_dir / report::run_files::kPlateForceBare,
                                report::SamplesToCsv(m_bare));
  if (m_stream) m_stream->Close();
  if (m_result_nonce.empty()) {
    report::WriteFileAtomically(m_dir / report::run_files::kSummary, summary_json.dump(2) + "\n");
  } else {
    nlohmann::json proven = summary_json;
    proven[report::kResultNonceKey] = m_result_nonce;
    report::WriteFileAtomically(m_dir / report::run_files::kSummary, proven.dump(2) + "\n");
  }
  report::WriteFileAtomically(m_dir / report::run_files::kLog, report::RunLogText(summary_json));
  m_summary = summary_json;
}

std::filesystem::path FolderRecorder::partial_samples() const {
  return m_csv && m_summary.is_null() ? m_csv->partial_path() : std::filesystem::path();
}

}  // namespace dembuf
