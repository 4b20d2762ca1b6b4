// The files of a run: plate_force.csv (the sampled series) and summary.json. The same writer
// serves a local run and results fetched from the daemon.
#pragma once

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "dembuf/study/impact.h"
#include "dembuf/study/scene.h"

namespace dembuf::report {

/// The scene as nested JSON: {"projectile": {"mass_kg": 0.167, ...}, ...}.
nlohmann::json SceneToJson(const Scene& scene);

/// The summary.json document of a finished run.
nlohmann::json SummaryToJson(const ImpactSummary& summary, const Scene& scene);

/// Streams samples to CSV. Writes to NAME.partial and renames to NAME on Commit(), so that a
/// file with the final name is always complete.
class SampleCsvWriter {
 public:
  explicit SampleCsvWriter(std::filesystem::path path);
  void Write(const ImpactSample& sample);
  void Commit();
  const std::filesystem::path& partial_path() const { return m_partial; }

 private:
  std::filesystem::path m_final;
  std::filesystem::path m_partial;
  std::ofstream m_out;
};

/// The files and folders a run writes into its folder (results, failure or interruption
/// reports, plots, snapshots), so that replacing a run removes all of the run before and
/// nothing else.
const std::vector<std::string>& RunOutputNames();

/// Removes the outputs of a run (RunOutputNames) from `dir`; other files stay.
void RemoveRunOutputs(const std::filesystem::path& dir);

/// Writes text to path atomically (temporary file, then rename).
void WriteFileAtomically(const std::filesystem::path& path, const std::string& text);

}  // namespace dembuf::report
