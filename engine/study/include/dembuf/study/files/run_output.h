// The files of a run: the names of a run folder's files (run_files), plate_force.csv (the
// sampled series), summary.json and the writers of both. The same writers serve a local run
// and results fetched from the daemon.
#pragma once

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "dembuf/study/files/provenance.h"
#include "dembuf/study/impact/impact.h"
#include "dembuf/study/scene/scene.h"

namespace dembuf::report {

/// The scene as nested JSON: {"projectile": {"mass_kg": 0.167, ...}, ...}.
nlohmann::json SceneToJson(const Scene& scene);

/// What a run found that its numbers alone do not say (a contact overlap beyond the small
/// strains Hertz theory assumes), as "what: why" sentences. SummaryToJson keeps them in
/// `warnings`, after the scene's (SceneWarnings); every caller prints them from there.
std::vector<std::string> ResultWarnings(const ImpactSummary& summary);

/// The run folder's log.txt from its summary.json: the provenance, then every warning.
std::string RunLogText(const nlohmann::json& summary);

/// One column of a force sample: its name (plate_force.csv's header) and where it is. Every
/// door that writes or sends samples takes its columns from SampleColumns(), so none drops one.
struct SampleColumn {
  const char* name;
  double ImpactSample::*member;
  bool of_projectile;  ///< empty (NaN) in a scene without a projectile
};
std::span<const SampleColumn> SampleColumns();

/// A column's value in a sample: NaN for a projectile's column when there is no projectile.
double SampleValue(const ImpactSample& sample, const SampleColumn& column);

/// The summary.json document of a finished run, with its provenance (provenance.h).
nlohmann::json SummaryToJson(const ImpactSummary& summary, const Scene& scene,
                             const RunContext& run);

/// The bed's measured height in a summary.json: `measured_thickness_m`, or in a summary of an
/// earlier dembuf `bed_thickness_m`; 0 where neither is a number.
double MeasuredThickness(const nlohmann::json& summary);

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

/// Samples as the text of plate_force.csv.
std::string SamplesToCsv(const std::vector<ImpactSample>& samples);
/// plate_force.csv's header and one of its rows, without the line's end (`dembuf watch --csv`
/// prints them between its index and state columns).
std::string SampleCsvColumns();
std::string SampleCsvCells(const ImpactSample& sample);

/// Samples as bytes: rows of six little-endian doubles (the columns of plate_force.csv), exact
/// to the bit. The daemon stores series so, and a cluster job streams them so.
std::string PackSamples(const std::vector<ImpactSample>& samples);
/// The whole rows of `bytes` (a trailing part row, still being written, is left out).
std::vector<ImpactSample> UnpackSamples(std::string_view bytes);
inline constexpr std::size_t kPackedSampleBytes = 6 * sizeof(double);

/// Streams samples, packed, to a file that another process follows while the run goes (the
/// daemon following a cluster job): the bytes reach the file at least every `flush_every`.
class SampleStreamWriter {
 public:
  explicit SampleStreamWriter(
      const std::filesystem::path& path,
      std::chrono::milliseconds flush_every = std::chrono::milliseconds(200));
  void Write(const ImpactSample& sample);
  /// Flushes; throws when the file could not be written.
  void Close();

 private:
  std::filesystem::path m_path;
  std::ofstream m_out;
  std::chrono::milliseconds m_flush_every;
  std::chrono::steady_clock::time_point m_last_flush;
};

/// A daemon's proof that a run's result is the run's it started on a cluster: the daemon puts a
/// random nonce in the job's environment as this variable, and `dembuf run` writes it into its
/// summary.json and failure.json under kResultNonceKey. A result without it is not taken.
inline constexpr const char* kResultNonceVariable = "DEMBUF_RESULT_NONCE";
inline constexpr const char* kResultNonceKey = "result_nonce";

/// A run folder's files, named here only: what writes a run folder (the folder recorder, the
/// CLI's failure reports, a fetch) and what reads one back (a local sweep, the Slurm executor,
/// plots) say these names.
namespace run_files {
inline constexpr const char* kScene = "scene.toml";
inline constexpr const char* kSummary = "summary.json";
inline constexpr const char* kFailure = "failure.json";
inline constexpr const char* kIncomplete = "incomplete.json";
inline constexpr const char* kPlateForce = "plate_force.csv";
/// The series while the run writes it (renamed to kPlateForce at its end).
inline constexpr const char* kPlateForcePartial = "plate_force.csv.partial";
inline constexpr const char* kPlateForceBare = "plate_force_bare.csv";
inline constexpr const char* kLog = "log.txt";
}  // namespace run_files

/// Whether `dir` holds a run's files (its scene, summary, failure or interruption report, or
/// its series being written), not something else's; links are not followed.
bool IsRunFolder(const std::filesystem::path& dir);

/// The files and folders a run writes into its folder (results, failure or interruption
/// reports, plots, snapshots), so that replacing a run removes all of the run before and
/// nothing else.
const std::vector<std::string>& RunOutputNames();

/// Removes the outputs of a run (RunOutputNames) from `dir`; other files stay.
void RemoveRunOutputs(const std::filesystem::path& dir);

/// Writes text to path atomically (temporary file, then rename).
void WriteFileAtomically(const std::filesystem::path& path, const std::string& text);

}  // namespace dembuf::report
