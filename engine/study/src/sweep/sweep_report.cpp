#include "dembuf/study/sweep/sweep_report.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <fstream>
#include <limits>
#include <map>

#include "dembuf/study/files/run_output.h"

namespace dembuf::report {

namespace {

std::string NumberText(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.12g", v);
  return buf;
}

// The axes a point is made of: all but the bed seed, over which a point is averaged.
std::vector<std::size_t> PointAxes(const std::vector<SweepAxis>& axes) {
  std::vector<std::size_t> point_axes;
  for (std::size_t a = 0; a < axes.size(); ++a)
    if (axes[a].field != "bed.seed") point_axes.push_back(a);
  return point_axes;
}

}  // namespace

const std::vector<std::string>& SweepMetricNames() {
  static const std::vector<std::string> names = {"P_N",
                                                 "Pa_N",
                                                 "Pb_N",
                                                 "lambda",
                                                 "crater_depth_m",
                                                 "bed_thickness_m",
                                                 "C0",
                                                 "dS_m",
                                                 "dt_peaks_s",
                                                 "load_duration_s",
                                                 "peak_plate_force_N",
                                                 "peak_plate_force_time_s",
                                                 "reference_peak_N",
                                                 "first_contact_time_s",
                                                 "max_overlap_ratio",
                                                 "beads",
                                                 "steps",
                                                 "wall_time_s"};
  return names;
}

nlohmann::json CriticalThickness(const std::vector<std::pair<double, double>>& h_to_p) {
  if (h_to_p.size() < 3) return nullptr;
  constexpr double kMargin = 0.10;
  const double h_min = h_to_p.front().first, h_max = h_to_p.back().first;
  const double middle = 0.5 * (h_min + h_max);
  double plateau = 0.0;
  std::vector<double> upper;  // mean P of the points in the upper half of the range
  for (const auto& [h, p] : h_to_p)
    if (h >= middle) upper.push_back(p);
  for (double p : upper) plateau += p / static_cast<double>(upper.size());
  // A plateau only where P has levelled off: across the upper half it changes by no more
  // than the margin. Otherwise there is no Hc in the range, whatever the rule below would say.
  const double change = (upper.back() - upper.front()) / plateau;
  nlohmann::json hc = {
      {"plateau_P_N", plateau},
      {"range_m", {h_min, h_max}},
      {"margin", kMargin},
      {"upper_half_change", change},
      {"rule",
       "the mean P over the upper half of the H range is a plateau only if P changes by at "
       "most the margin across that half; Hc is then the smallest H from which mean P stays "
       "within the margin above the plateau"}};
  if (upper.size() < 2 || std::abs(change) > kMargin) {
    char note[160];
    if (upper.size() < 2)
      std::snprintf(note, sizeof note,
                    "Hc not reached in %.3g-%.3g cm (one point in the upper half: no plateau "
                    "to tell)",
                    100 * h_min, 100 * h_max);
    else
      std::snprintf(note, sizeof note,
                    "Hc not reached in %.3g-%.3g cm (P still %s %.0f%% over the upper half)",
                    100 * h_min, 100 * h_max, change < 0 ? "falls" : "rises",
                    100 * std::abs(change));
    hc["Hc_m"] = nullptr;
    hc["reached"] = false;
    hc["note"] = note;
    return hc;
  }
  double h_c = h_max;
  for (auto it = h_to_p.rbegin(); it != h_to_p.rend(); ++it) {
    if (it->second > (1.0 + kMargin) * plateau) break;
    h_c = it->first;
  }
  hc["Hc_m"] = h_c;
  hc["reached"] = true;
  return hc;
}

nlohmann::json SweepValueJson(const std::string& text) {
  const char* begin = text.data();
  const char* end = begin + text.size();
  std::int64_t whole = 0;
  if (auto [ptr, ec] = std::from_chars(begin, end, whole); ec == std::errc() && ptr == end)
    return whole;
  double number = 0.0;
  if (auto [ptr, ec] = std::from_chars(begin, end, number);
      ec == std::errc() && ptr == end && std::isfinite(number))
    return number;
  return text;
}

nlohmann::json SweepValuesJson(const std::vector<std::string>& texts) {
  nlohmann::json values = nlohmann::json::array();
  for (const std::string& text : texts) values.push_back(SweepValueJson(text));
  return values;
}

std::string RunStatus(const SweepRunReport& run) {
  if (!run.state.empty()) return run.state;
  return run.ok ? "done" : "failed";
}

nlohmann::json SweepPoints(const std::vector<SweepAxis>& axes,
                           const std::vector<SweepRunReport>& runs) {
  const std::vector<std::size_t> point_axes = PointAxes(axes);
  std::map<std::vector<std::string>, std::vector<std::size_t>> points;
  for (std::size_t j = 0; j < runs.size(); ++j) {
    std::vector<std::string> key;
    for (std::size_t a : point_axes) key.push_back(runs[j].values.at(a));
    points[key].push_back(j);
  }
  nlohmann::json point_list = nlohmann::json::array();
  for (const auto& [key, members] : points) {
    nlohmann::json point;
    for (std::size_t k = 0; k < point_axes.size(); ++k)
      point[axes[point_axes[k]].field] = SweepValueJson(key[k]);
    point["runs"] = members.size();
    for (const auto& m : SweepMetricNames()) {
      std::vector<double> v;
      for (std::size_t j : members)
        if (runs[j].ok && runs[j].summary.contains(m) && runs[j].summary[m].is_number())
          v.push_back(runs[j].summary[m].get<double>());
      if (v.empty()) continue;
      double mean = 0.0, var = 0.0;
      for (double x : v) mean += x / v.size();
      for (double x : v) var += (x - mean) * (x - mean);
      // One run has no spread: its sd is left empty (null), not 0.
      point[m] = {
          {"mean", mean},
          {"sd", v.size() > 1 ? nlohmann::json(std::sqrt(var / (v.size() - 1))) : nlohmann::json()},
          {"n", v.size()}};
    }
    point_list.push_back(point);
  }
  return point_list;
}

nlohmann::json WriteSweepReport(const std::filesystem::path& dir,
                                const std::vector<SweepAxis>& axes,
                                const std::vector<SweepRunReport>& runs,
                                const nlohmann::json& extra, std::FILE* table) {
  std::filesystem::create_directories(dir);
  // sweep.csv: one row per run.
  std::ofstream csv(dir / "sweep.csv");
  csv << "run,id";
  for (const auto& axis : axes) csv << "," << axis.field;
  csv << ",status";
  for (const auto& m : SweepMetricNames()) csv << "," << m;
  csv << ",run_dir,error\n";
  csv.precision(10);
  int failed = 0;
  for (std::size_t j = 0; j < runs.size(); ++j) {
    const SweepRunReport& r = runs[j];
    csv << j << ",";
    if (r.id != 0) csv << r.id;
    for (const auto& v : r.values) csv << "," << v;
    csv << "," << RunStatus(r);
    for (const auto& m : SweepMetricNames()) {
      csv << ",";
      if (r.ok && r.summary.contains(m) && r.summary[m].is_number())
        csv << r.summary[m].get<double>();
    }
    std::string error = r.error;
    std::replace(error.begin(), error.end(), '"', '\'');
    csv << ",runs/" << r.name << ",\"" << error << "\"\n";
    failed += !r.ok;
  }

  const std::vector<std::size_t> point_axes = PointAxes(axes);
  const nlohmann::json point_list = SweepPoints(axes, runs);
  std::vector<std::pair<double, double>> h_to_p;
  // points.csv: one row per point, each metric's mean, sd and n (what the plots read).
  std::ofstream points_csv(dir / "points.csv");
  points_csv.precision(10);
  for (std::size_t k = 0; k < point_axes.size(); ++k)
    points_csv << (k ? "," : "") << axes[point_axes[k]].field;
  for (const auto& m : SweepMetricNames())
    points_csv << "," << m << "," << m << "_sd," << m << "_n";
  points_csv << "\n";
  std::fprintf(table, "\n");
  for (std::size_t a : point_axes) std::fprintf(table, "%-22s", axes[a].field.c_str());
  std::fprintf(table, "%4s %22s %18s %16s %8s\n", "n", "P [N] mean +- sd", "lambda [%]",
               "crater [cm]", "C0");
  for (const nlohmann::json& point : point_list) {
    std::vector<std::string> key;
    for (std::size_t a : point_axes) {
      const nlohmann::json& value = point[axes[a].field];
      key.push_back(value.is_string() ? value.get<std::string>() : value.dump());
    }
    // mean and sd (NaN for one run) of the metrics that have values
    std::map<std::string, std::pair<double, double>> stats;
    for (const auto& m : SweepMetricNames())
      if (point.contains(m))
        stats[m] = {point[m]["mean"].get<double>(), point[m]["sd"].is_null()
                                                        ? std::numeric_limits<double>::quiet_NaN()
                                                        : point[m]["sd"].get<double>()};
    for (std::size_t k = 0; k < key.size(); ++k) points_csv << (k ? "," : "") << key[k];
    for (const auto& m : SweepMetricNames()) {
      if (stats.count(m)) {
        points_csv << "," << stats[m].first << ",";
        if (!std::isnan(stats[m].second)) points_csv << stats[m].second;
        points_csv << "," << point[m]["n"].get<std::size_t>();
      } else {
        points_csv << ",,,0";
      }
    }
    points_csv << "\n";
    for (const auto& k : key) std::fprintf(table, "%-22s", k.c_str());
    auto ms = [&](const char* m, double scale) {
      char buf[48];
      if (!stats.count(m)) return std::string("-");
      if (std::isnan(stats[m].second))
        std::snprintf(buf, sizeof buf, "%.4g", stats[m].first * scale);
      else
        std::snprintf(buf, sizeof buf, "%.4g +- %.2g", stats[m].first * scale,
                      stats[m].second * scale);
      return std::string(buf);
    };
    std::fprintf(
        table, "%4zu %22s %18s %16s %8s\n", point["runs"].get<std::size_t>(), ms("P_N", 1).c_str(),
        ms("lambda", 100).c_str(), ms("crater_depth_m", 100).c_str(),
        stats.count("C0") ? NumberText(std::round(stats["C0"].first * 1000) / 1000).c_str() : "-");
    if (point_axes.size() == 1 && axes[point_axes[0]].field == "bed.thickness_m" &&
        stats.count("P_N"))
      h_to_p.push_back({std::stod(key[0]), stats["P_N"].first});
  }
  std::sort(h_to_p.begin(), h_to_p.end());

  nlohmann::json summary = {
      {"runs", runs.size()},
      {"failed", failed},
      {"axes", nlohmann::json::array()},
      {"points", point_list},
  };
  summary.update(extra);
  for (const auto& axis : axes)
    summary["axes"].push_back({{"field", axis.field}, {"values", SweepValuesJson(axis.values)}});
  if (!h_to_p.empty() && !summary.contains("critical_thickness")) {
    const nlohmann::json hc = CriticalThickness(h_to_p);
    if (!hc.is_null()) {
      summary["Hc_m"] = hc["Hc_m"];
      summary["critical_thickness"] = hc;
      if (hc["reached"].get<bool>())
        std::fprintf(table, "critical thickness Hc = %.2f cm (plateau P = %.4g N)\n",
                     100 * hc["Hc_m"].get<double>(), hc["plateau_P_N"].get<double>());
      else
        std::fprintf(table, "%s\n", hc["note"].get<std::string>().c_str());
    }
  }
  WriteFileAtomically(dir / "summary.json", summary.dump(2) + "\n");
  return summary;
}

}  // namespace dembuf::report
