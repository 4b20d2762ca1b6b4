// A run recorded into a folder, as `dembuf run`, each run of a local sweep and a cluster job
// write it:
//   scene.toml            the resolved scene (written when the recorder is made)
//   plate_force.csv       the samples (plate_force.csv.partial while the run goes)
//   plate_force_bare.csv  the same impact on the bare plate
//   snapshots/, frames/   with snapshots.pvd and frames.pvd (snapshot_report.h)
//   summary.json          when the run ends well
// Every file is written whole under a temporary name and renamed, so that a file with its
// final name is complete.
#pragma once

#include <filesystem>
#include <optional>
#include <vector>

#include "dembuf/study/files/run_output.h"
#include "dembuf/study/run/run_job.h"

namespace dembuf {

class FolderRecorder final : public RunRecorder {
 public:
  /// Records into `dir` (made when missing); with `samples_stream` also streams the samples,
  /// packed, to that file as they come (a daemon following a cluster job reads it), and with
  /// `result_nonce` writes that daemon's nonce into summary.json (report::kResultNonceKey).
  FolderRecorder(std::filesystem::path dir, const Scene& scene,
                 std::filesystem::path samples_stream = {}, std::string result_nonce = {});

  void Sample(const ImpactSample& sample) override;
  void ReferenceSample(const ImpactSample& sample) override;
  void Files(const std::vector<report::ResultFile>& files) override;
  void Finished(const ImpactSummary& summary, const nlohmann::json& summary_json) override;

  /// The samples written so far, while the run has not finished ("" before the first).
  std::filesystem::path partial_samples() const;
  const std::filesystem::path& dir() const { return m_dir; }
  /// summary.json's document, once the run finished (null before).
  const nlohmann::json& summary_json() const { return m_summary; }

 private:
  std::filesystem::path m_dir;
  std::filesystem::path m_stream_path;
  std::string m_result_nonce;
  std::optional<report::SampleCsvWriter> m_csv;  ///< opened at the first sample
  std::optional<report::SampleStreamWriter> m_stream;
  std::vector<ImpactSample> m_bare;  ///< a few hundred samples, written at the end
  nlohmann::json m_summary;
};

}  // namespace dembuf
