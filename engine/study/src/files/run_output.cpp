#include "dembuf/study/files/run_output.h"

#include <bit>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <iterator>
#include <limits>
#include <stdexcept>

#include "dembuf/study/files/own_files.h"
#include "dembuf/study/scene/scene_fields.h"
#include "dembuf/study/text/text_limits.h"
#include "dembuf/study/version.h"

namespace dembuf::report {

nlohmann::json SceneToJson(const Scene& scene) {
  nlohmann::json out = nlohmann::json::object();
  for (const SceneField& f : SceneFields()) {
    // The field table's own text form is TOML, which JSON parses for numbers, booleans and
    // the quoted strings it writes.
    nlohmann::json value = nlohmann::json::parse(FormatSceneField(scene, f));
    auto dot = f.name.find('.');
    if (dot == std::string_view::npos) {
      out[std::string(f.name)] = value;
    } else {
      out[std::string(f.name.substr(0, dot))][std::string(f.name.substr(dot + 1))] = value;
    }
  }
  return out;
}

std::vector<std::string> ResultWarnings(const ImpactSummary& s) {
  std::vector<std::string> warnings;
  // Hertz's law is derived for small strains (docs/model.md); past a tenth of a radius the
  // contact forces are extrapolated.
  if (s.max_overlap_ratio > 0.1)
    warnings.push_back("max_overlap_ratio: the largest contact overlap reached " +
                       std::to_string(static_cast<int>(std::lround(100 * s.max_overlap_ratio))) +
                       "% of a bead radius, beyond the small strains Hertz theory assumes");
  for (const std::string& w : s.bed.warnings) warnings.push_back(w);
  return warnings;
}

std::string RunLogText(const nlohmann::json& summary) {
  if (!summary.is_object()) return "";
  // A line of text for people, whoever wrote the summary (a server's may hold escapes that a
  // terminal would obey, or line breaks that forge a line): control characters shown as '?'.
  auto line = [](const nlohmann::json& value) {
    return PrintableText(value.is_string() ? value.get<std::string>() : value.dump());
  };
  std::string text;
  const nlohmann::json provenance = summary.value("provenance", nlohmann::json::object());
  std::string timeline;
  if (provenance.is_object())
    for (const auto& [key, value] : provenance.items()) {
      if (key == "timeline" && value.is_array()) {  // a line each, after the other lines
        for (const nlohmann::json& event : value) timeline += line(event) + "\n";
        continue;
      }
      text += PrintableText(key) + ": " + line(value) + "\n";
    }
  if (!timeline.empty()) text += "what the run did (UTC):\n" + timeline;
  const nlohmann::json warnings = summary.value("warnings", nlohmann::json::array());
  if (!warnings.is_array() || warnings.empty()) text += "no warnings\n";
  if (warnings.is_array())
    for (const nlohmann::json& w : warnings) text += "warning: " + line(w) + "\n";
  return text;
}

nlohmann::json SummaryToJson(const ImpactSummary& s, const Scene& scene, const RunContext& run) {
  std::vector<std::string> warnings = SceneWarnings(scene);
  for (std::string& w : ResultWarnings(s)) warnings.push_back(std::move(w));
  nlohmann::json curve = nlohmann::json::array();
  for (const auto& point : s.contact_damping.restitution_curve)
    curve.push_back({{"speed_m_s", point.speed_m_s}, {"restitution", point.restitution}});
  nlohmann::json j = {
      {"dembuf_version", kVersion},
      {"peak_plate_force_N", s.peak_plate_force_N},
      {"peak_plate_force_time_s", s.peak_plate_force_time_s},
      {"beads", s.beads},
      {"dt_s", s.dt_s},
      {"critical_dt_s", s.critical_dt_s},
      {"alpha", scene.time.alpha},
      {"steps", s.steps},
      {"wall_time_s", s.wall_time_s},
      {"damping",
       {{"A_s", s.contact_damping.damping_A_s},
        {"target_restitution", s.contact_damping.target_restitution},
        {"v_ref_m_s", s.contact_damping.ref_speed_m_s},
        {"e_at_vref", s.contact_damping.restitution_at_ref},
        {"restitution_vs_speed", curve}}},
      {"bed_surface_m", s.bed_surface_m},
      {"free_flight_s", s.free_flight_s},
      {"impact_speed_m_s", s.impact_speed_m_s},
      {"end_time_s", s.end_time_s},
      {"end_reason", s.end_reason},
      {"scene", SceneToJson(scene)},
      {"warnings", warnings},
      {"provenance", ProvenanceJson(run, scene, s.bed)},
  };
  // The paper's measurements (docs/model.md section 6).
  const PeakAnalysis& pk = s.peaks;
  auto optional = [](bool has, double v) { return has ? nlohmann::json(v) : nlohmann::json(); };
  j["P_N"] = pk.p_N;
  j["P_time_s"] = pk.p_time_s;
  j["Pa_N"] = optional(pk.has_pa, pk.pa.force_N);
  j["Pa_time_s"] = optional(pk.has_pa, pk.pa.time_s);
  j["Pb_N"] = optional(pk.has_pb, pk.pb.force_N);
  j["Pb_time_s"] = optional(pk.has_pb, pk.pb.time_s);
  j["dS_m"] = optional(pk.has_pa && pk.has_pb, pk.ds_m);
  j["dt_peaks_s"] = optional(pk.has_pa && pk.has_pb, pk.dt_peaks_s);
  j["load_duration_s"] = pk.load_duration_s;
  j["lambda"] = s.lambda;
  j["reference_peak_N"] = s.reference_peak_N;
  j["reference_first_contact_time_s"] = s.reference_first_contact_time_s >= 0.0
                                            ? nlohmann::json(s.reference_first_contact_time_s)
                                            : nlohmann::json();
  j["crater_depth_m"] = s.crater_depth_m;
  j["max_overlap_ratio"] = s.max_overlap_ratio;
  j["measured_thickness_m"] = s.bed.thickness_m;
  j["C0"] = s.bed.solid_fraction;
  j["bed"] = {{"hash", s.bed.hash},
              {"rest_plate_force_N", s.bed.rest_plate_force_N},
              {"rest_wall_force_z_N", s.bed.rest_wall_force_z_N},
              {"weight_N", s.bed.weight_N}};
  if (!s.bed.note.empty()) j["bed"]["imported"] = s.bed.note;
  if (!s.bed.layers.empty()) {
    // A bed of several species or layers: each layer from the plate up, as measured.
    nlohmann::json layers = nlohmann::json::array();
    for (const LayerSummary& layer : s.bed.layers) {
      nlohmann::json beads = nlohmann::json::object();
      for (std::size_t k = 0; k < layer.beads.size(); ++k) beads[s.bed.species[k]] = layer.beads[k];
      layers.push_back({{"bottom_m", layer.bottom_m},
                        {"top_m", layer.top_m},
                        {"asked_top_m", layer.asked_top_m},
                        {"thickness_m", layer.top_m - layer.bottom_m},
                        {"C0", layer.solid_fraction},
                        {"beads", beads}});
    }
    j["bed"]["layers"] = layers;
  }
  // Each peak named once: Pa the largest push, Pb the largest wave, the others bumps (of
  // either kind, as `push` says).
  auto is = [](const ForcePeak& a, const ForcePeak& b) {
    return a.time_s == b.time_s && a.force_N == b.force_N;
  };
  nlohmann::json peaks = nlohmann::json::array();
  for (const ForcePeak& p : pk.peaks)
    peaks.push_back({{"force_N", p.force_N},
                     {"time_s", p.time_s},
                     {"kind", pk.has_pa && is(p, pk.pa)   ? "Pa"
                              : pk.has_pb && is(p, pk.pb) ? "Pb"
                                                          : "bump"},
                     {"push", p.is_push},
                     {"projectile_z_m", p.projectile_z_m}});
  j["peaks"] = peaks;
  j["first_contact_time_s"] =
      s.first_contact_time_s >= 0.0 ? nlohmann::json(s.first_contact_time_s) : nlohmann::json();
  return j;
}

double MeasuredThickness(const nlohmann::json& summary) {
  for (const char* key : {"measured_thickness_m", "bed_thickness_m"})
    if (summary.is_object() && summary.contains(key) && summary[key].is_number())
      return summary[key].get<double>();
  return 0.0;
}

std::span<const SampleColumn> SampleColumns() {
  static const SampleColumn columns[] = {
      {"t_s", &ImpactSample::t_s, false},
      {"plate_force_N", &ImpactSample::plate_force_N, false},
      {"wall_force_z_N", &ImpactSample::wall_force_z_N, false},
      {"proj_z_m", &ImpactSample::projectile_z_m, true},
      {"proj_vz_m_s", &ImpactSample::projectile_vz_m_s, true},
      {"proj_force_z_N", &ImpactSample::projectile_force_z_N, true}};
  return columns;
}

double SampleValue(const ImpactSample& sample, const SampleColumn& column) {
  if (column.of_projectile && !std::isfinite(sample.projectile_z_m))
    return std::numeric_limits<double>::quiet_NaN();
  return sample.*column.member;
}

std::string SampleCsvColumns() {
  std::string text;
  for (const SampleColumn& c : SampleColumns()) {
    if (!text.empty()) text += ',';
    text += c.name;
  }
  return text;
}

namespace {

// plate_force.csv's first line, from the columns.
const std::string& SampleCsvHeader() {
  static const std::string header = SampleCsvColumns() + "\n";
  return header;
}

// One row of plate_force.csv; returns its length. An empty cell for a value that is not
// there (a scene without a projectile).
int SampleCsvRow(const ImpactSample& s, char (&line)[256]) {
  int n = 0;
  for (const SampleColumn& c : SampleColumns()) {
    if (n > 0) line[n++] = ',';
    const double v = SampleValue(s, c);
    if (std::isfinite(v)) n += std::snprintf(line + n, sizeof line - n, "%.9g", v);
  }
  line[n++] = '\n';
  line[n] = '\0';
  return n;
}

}  // namespace

SampleCsvWriter::SampleCsvWriter(std::filesystem::path path)
    : m_final(std::move(path)), m_partial(m_final.string() + ".partial") {
  m_out.open(m_partial);
  if (!m_out) throw std::runtime_error("cannot write " + m_partial.string());
  m_out << SampleCsvHeader();
}

void SampleCsvWriter::Write(const ImpactSample& s) {
  char line[256];
  m_out.write(line, SampleCsvRow(s, line));
}

std::string SampleCsvCells(const ImpactSample& sample) {
  char line[256];
  return std::string(line, SampleCsvRow(sample, line) - 1);
}

std::string SamplesToCsv(const std::vector<ImpactSample>& samples) {
  std::string text = SampleCsvHeader();
  char line[256];
  for (const ImpactSample& s : samples) text.append(line, SampleCsvRow(s, line));
  return text;
}

void SampleCsvWriter::Commit() {
  m_out.close();
  if (!m_out) throw std::runtime_error("error writing " + m_partial.string());
  std::filesystem::rename(m_partial, m_final);
}

std::string PackSamples(const std::vector<ImpactSample>& samples) {
  static_assert(std::endian::native == std::endian::little, "packed samples are little-endian");
  std::string bytes(samples.size() * kPackedSampleBytes, '\0');
  char* out = bytes.data();
  for (const ImpactSample& s : samples) {
    const double row[6] = {s.t_s,
                           s.plate_force_N,
                           s.wall_force_z_N,
                           s.projectile_z_m,
                           s.projectile_vz_m_s,
                           s.projectile_force_z_N};
    std::memcpy(out, row, sizeof row);
    out += sizeof row;
  }
  return bytes;
}

std::vector<ImpactSample> UnpackSamples(std::string_view bytes) {
  std::vector<ImpactSample> samples(bytes.size() / kPackedSampleBytes);
  const char* in = bytes.data();
  for (ImpactSample& s : samples) {
    double row[6];
    std::memcpy(row, in, sizeof row);
    in += sizeof row;
    s = {row[0], row[1], row[2], row[3], row[4], row[5]};
  }
  return samples;
}

SampleStreamWriter::SampleStreamWriter(const std::filesystem::path& path,
                                       std::chrono::milliseconds flush_every)
    : m_path(path), m_out(path, std::ios::binary | std::ios::trunc), m_flush_every(flush_every) {
  if (!m_out) throw std::runtime_error("cannot write " + path.string());
  m_last_flush = std::chrono::steady_clock::now();
}

void SampleStreamWriter::Write(const ImpactSample& sample) {
  const std::string bytes = PackSamples({sample});
  m_out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  const auto now = std::chrono::steady_clock::now();
  if (now - m_last_flush >= m_flush_every) {
    m_out.flush();
    m_last_flush = now;
  }
}

void SampleStreamWriter::Close() {
  m_out.close();
  if (!m_out) throw std::runtime_error("error writing " + m_path.string());
}

const std::vector<std::string>& RunOutputNames() {
  static const std::vector<std::string> names = {run_files::kSummary,
                                                 run_files::kFailure,
                                                 run_files::kIncomplete,
                                                 run_files::kPlateForce,
                                                 run_files::kPlateForcePartial,
                                                 "plate_force.png",
                                                 "plate_force.svg",
                                                 run_files::kPlateForceBare,
                                                 "plate_force.gp",
                                                 "snapshots",
                                                 "snapshots.pvd",
                                                 "frames",
                                                 "frames.pvd",
                                                 "container.vtp",
                                                 run_files::kScene,
                                                 "job.json",
                                                 run_files::kLog};
  return names;
}

bool IsRunFolder(const std::filesystem::path& dir) {
  for (const char* name : {run_files::kSummary, run_files::kScene, run_files::kFailure,
                           run_files::kIncomplete, run_files::kPlateForcePartial})
    if (std::filesystem::is_regular_file(std::filesystem::symlink_status(dir / name))) return true;
  return false;
}

void RemoveRunOutputs(const std::filesystem::path& dir) {
  for (const std::string& name : RunOutputNames()) std::filesystem::remove_all(dir / name);
}

void WriteFileAtomically(const std::filesystem::path& path, const std::string& text) {
  const std::filesystem::path tmp = path.string() + ".tmp";
  std::filesystem::remove(tmp);  // a link of that name is removed, not written through
  {
    std::ofstream out(tmp);
    out << text;
    out.close();
    if (!out) throw std::runtime_error("cannot write " + tmp.string());
  }
  CloseToOthersWriting(tmp);  // (own_files.h)
  std::filesystem::rename(tmp, path);
}

}  // namespace dembuf::report
