#include "local/compare.h"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <stdexcept>

#include "dembuf/study/files/run_output.h"
#include "dembuf/study/sweep/paper_comparison.h"
#include "dembuf/study/sweep/sweep_report.h"
#include "local/plots.h"

namespace dembuf::cli {

namespace fs = std::filesystem;

namespace {

// A summary.json is a few kB; a file far larger is no summary.
constexpr std::uintmax_t kMaxSummaryBytes = 4 << 20;

nlohmann::json ReadSummary(const fs::path& path) {
  if (fs::file_size(path) > kMaxSummaryBytes)
    throw std::runtime_error(path.string() + " is too large for a summary.json");
  std::ifstream in(path);
  try {
    return nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {
    throw std::runtime_error(path.string() + " is not JSON: " + e.what());
  }
}

struct Runs {
  std::vector<nlohmann::json> summaries;
  std::optional<double> hc_m;
  double hc_sd_m = std::numeric_limits<double>::quiet_NaN();
  std::set<std::string> seen;        ///< each run's scene and bed, once
  std::vector<fs::path> duplicates;  ///< runs already counted from another folder
  void Add(const fs::path& summary_path);
};

// A run is its scene and its bed: the same run found in two folders (a sweep and a `dembuf
// run` of one of its points, a folder given twice) counts once.
void Runs::Add(const fs::path& summary_path) {
  nlohmann::json summary = ReadSummary(summary_path);
  const nlohmann::json bed = summary.value("bed", nlohmann::json::object());
  const std::string key = summary.value("scene", nlohmann::json()).dump() + "\n" +
                          (bed.is_object() ? bed.value("hash", std::string()) : std::string());
  if (!seen.insert(key).second) {
    duplicates.push_back(summary_path.parent_path());
    return;
  }
  summaries.push_back(std::move(summary));
}

// The runs of a run folder or a sweep folder (its runs/ that finished).
void ReadFolder(const fs::path& dir, Runs& runs) {
  if (fs::is_directory(dir / sweep_files::kRuns)) {
    for (const auto& entry : fs::directory_iterator(dir / sweep_files::kRuns))
      if (fs::is_regular_file(entry.path() / report::run_files::kSummary))
        runs.Add(entry.path() / report::run_files::kSummary);
    if (fs::is_regular_file(dir / sweep_files::kSummary)) {
      const nlohmann::json sweep = ReadSummary(dir / sweep_files::kSummary);
      if (sweep.contains("Hc_m") && sweep["Hc_m"].is_number()) {
        runs.hc_m = sweep["Hc_m"].get<double>();
        const nlohmann::json hc = sweep.value("critical_thickness", nlohmann::json::object());
        if (hc.is_object() && hc.contains("Hc_sd_m") && hc["Hc_sd_m"].is_number())
          runs.hc_sd_m = hc["Hc_sd_m"].get<double>();
      }
    }
    return;
  }
  if (fs::is_regular_file(dir / report::run_files::kSummary)) {
    runs.Add(dir / report::run_files::kSummary);
    return;
  }
  throw std::runtime_error(dir.string() +
                           " holds neither a run (summary.json) nor a sweep (runs/)");
}

// P and lambda at each thickness (mean, sd, n), for the plot; returns the largest thickness.
double WritePoints(const std::vector<nlohmann::json>& summaries, const fs::path& path) {
  std::map<double, std::vector<const nlohmann::json*>> by_h;
  for (const auto& s : summaries)
    by_h[std::round(s["scene"]["bed"]["thickness_m"].get<double>() * 1e7) / 1e7].push_back(&s);
  std::ofstream out(path);
  out.precision(10);
  // What the paper gives as curves over H: P and lambda, and between the two peaks the
  // projectile's travel dS and the time dt (its fits), with the strike peak Pb.
  out << "H_m,P_N,P_N_sd,lambda,lambda_sd,dS_m,dS_m_sd,dt_peaks_s,dt_peaks_s_sd,Pb_N,Pb_N_sd,n\n";
  for (const auto& point : by_h) {
    const std::vector<const nlohmann::json*>& runs = point.second;
    auto stats = [&](const char* key) {
      std::vector<double> v;
      for (const auto* s : runs)
        if (s->contains(key) && (*s)[key].is_number()) v.push_back((*s)[key].get<double>());
      double mean = 0.0, var = 0.0;
      for (double x : v) mean += x / v.size();
      for (double x : v) var += (x - mean) * (x - mean);
      std::string sd = v.size() > 1 ? std::to_string(std::sqrt(var / (v.size() - 1))) : "";
      return (v.empty() ? "" : std::to_string(mean)) + "," + sd;  // "": none has it
    };
    out << point.first << "," << stats("P_N") << "," << stats("lambda") << "," << stats("dS_m")
        << "," << stats("dt_peaks_s") << "," << stats("Pb_N") << "," << runs.size() << "\n";
  }
  return by_h.empty() ? 0.0 : by_h.rbegin()->first;
}

}  // namespace

int CompareCommand(const std::vector<fs::path>& folders, const fs::path& out_dir, bool plots) {
  Runs runs;
  for (const fs::path& dir : folders) ReadFolder(dir, runs);
  if (runs.summaries.empty())
    throw std::runtime_error("no finished run in " + folders.front().string());
  const Comparison c = CompareWithPaper(runs.summaries, runs.hc_m, runs.hc_sd_m);
  std::printf("%zu runs beside the paper", runs.summaries.size());
  if (!runs.duplicates.empty())
    std::printf(" (%zu more found twice, the same scene and bed, counted once: %s%s)",
                runs.duplicates.size(), runs.duplicates.front().c_str(),
                runs.duplicates.size() > 1 ? ", ..." : "");
  std::printf("\n%s", ComparisonTable(c).c_str());
  const fs::path out = out_dir.empty() ? folders.front() : out_dir;
  fs::create_directories(out);
  report::WriteFileAtomically(out / "compare.csv", ComparisonCsv(c));
  const double h_max = WritePoints(runs.summaries, out / "compare_points.csv");
  std::printf("wrote %s\n", (out / "compare.csv").c_str());
  if (plots && c.is_paper_e2 && GnuplotAvailable())
    std::printf("wrote %s\n", PlotComparison(out, c.hertz_peak_N, h_max, c.variant).c_str());
  return 0;
}

}  // namespace dembuf::cli
