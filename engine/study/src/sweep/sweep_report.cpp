#include "dembuf/study/sweep/sweep_report.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <fstream>
#include <limits>
#include <map>

#include "dembuf/study/files/run_output.h"
#include "dembuf/study/text/number_text.h"

namespace dembuf {

namespace {

// The axes a point is made of: all but the bed seed, over which a point is averaged.
std::vector<std::size_t> PointAxes(const std::vector<SweepAxis>& axes) {
  std::vector<std::size_t> point_axes;
  for (std::size_t a = 0; a < axes.size(); ++a)
    if (axes[a].field != "bed.seed") point_axes.push_back(a);
  return point_axes;
}

// A JSON value as a CSV cell: a number exactly, in its shortest text (swept values 2e-14
// apart stay apart, and a reader gets the JSON's doubles); a text quoted where it holds a
// comma, a quote or a line's end; null empty.
std::string CsvCell(const nlohmann::json& value) {
  if (value.is_number_integer()) return std::to_string(value.get<std::int64_t>());
  if (value.is_number()) {
    char text[32];
    return std::string(text, std::to_chars(text, text + sizeof text, value.get<double>()).ptr);
  }
  if (!value.is_string()) return "";
  const std::string text = value.get<std::string>();
  if (text.find_first_of(",\"\n\r") == std::string::npos) return text;
  std::string quoted = "\"";
  for (char c : text) quoted += c == '"' ? std::string("\"\"") : std::string(1, c);
  return quoted + "\"";
}

// Points in the order of their values: numbers by value (2 before 10), text by characters,
// a number before a text.
struct ValuesOrder {
  bool operator()(const std::vector<std::string>& a, const std::vector<std::string>& b) const {
    for (std::size_t k = 0; k < std::min(a.size(), b.size()); ++k) {
      const nlohmann::json x = SweepValueJson(a[k]), y = SweepValueJson(b[k]);
      const bool x_number = x.is_number(), y_number = y.is_number();
      if (x_number != y_number) return x_number;
      if (x_number && x.get<double>() != y.get<double>()) return x.get<double>() < y.get<double>();
      if (!x_number && a[k] != b[k]) return a[k] < b[k];
      if (x_number && a[k] != b[k]) return a[k] < b[k];  // equal values, other texts (1, 1.0)
    }
    return a.size() < b.size();
  }
};

// The table of points on the terminal: the swept values, runs, and P, lambda, crater depth
// and C0 as mean +- sd.
void PrintPoints(const std::vector<SweepAxis>& axes, const nlohmann::json& points,
                 std::FILE* table) {
  const std::vector<std::size_t> point_axes = PointAxes(axes);
  std::fprintf(table, "\n");
  for (std::size_t a : point_axes) std::fprintf(table, "%-22s", axes[a].field.c_str());
  std::fprintf(table, "%4s %22s %18s %16s %8s\n", "n", "P [N] mean +- sd", "lambda [%]",
               "crater [cm]", "C0");
  for (const nlohmann::json& point : points) {
    for (std::size_t a : point_axes) {
      const nlohmann::json& value = point[axes[a].field];
      std::fprintf(table, "%-22s",
                   (value.is_string() ? value.get<std::string>() : value.dump()).c_str());
    }
    auto cell = [&](const std::string& m, double scale) {
      char text[48] = "-";
      if (point[m].is_number() && point[m + "_sd"].is_number())
        std::snprintf(text, sizeof text, "%.4g +- %.2g", point[m].get<double>() * scale,
                      point[m + "_sd"].get<double>() * scale);
      else if (point[m].is_number())
        std::snprintf(text, sizeof text, "%.4g", point[m].get<double>() * scale);
      return std::string(text);
    };
    std::fprintf(table, "%4zu %22s %18s %16s %8s\n", point["runs"].get<std::size_t>(),
                 cell("P_N", 1).c_str(), cell("lambda", 100).c_str(),
                 cell("crater_depth_m", 100).c_str(),
                 point["C0"].is_number()
                     ? NumberText(std::round(point["C0"].get<double>() * 1000) / 1000, 12).c_str()
                     : "-");
  }
}

}  // namespace

const std::vector<std::string>& SweepMetricNames() {
  static const std::vector<std::string> names = {"P_N",
                                                 "Pa_N",
                                                 "Pb_N",
                                                 "lambda",
                                                 "crater_depth_m",
                                                 "measured_thickness_m",
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

std::vector<std::string> SweepPointColumns(const std::vector<SweepAxis>& axes) {
  std::vector<std::string> columns;
  for (std::size_t a : PointAxes(axes)) columns.push_back(axes[a].field);
  columns.push_back("runs");
  for (const std::string& m : SweepMetricNames()) {
    columns.push_back(m);
    columns.push_back(m + "_sd");
    columns.push_back(m + "_n");
  }
  return columns;
}

nlohmann::json SweepPoints(const std::vector<SweepAxis>& axes,
                           const std::vector<SweepRunReport>& runs) {
  const std::vector<std::size_t> point_axes = PointAxes(axes);
  std::map<std::vector<std::string>, std::vector<std::size_t>, ValuesOrder> points;
  for (std::size_t j = 0; j < runs.size(); ++j) {
    std::vector<std::string> key;
    for (std::size_t a : point_axes) key.push_back(runs[j].values.at(a));
    points[key].push_back(j);
  }
  nlohmann::json point_list = nlohmann::json::array();
  for (const auto& [key, members] : points) {
    nlohmann::json point = nlohmann::json::object();
    for (std::size_t k = 0; k < point_axes.size(); ++k)
      point[axes[point_axes[k]].field] = SweepValueJson(key[k]);
    point["runs"] = members.size();
    for (const std::string& m : SweepMetricNames()) {
      std::vector<double> v;
      for (std::size_t j : members)
        if (runs[j].ok && runs[j].summary.contains(m) && runs[j].summary[m].is_number())
          v.push_back(runs[j].summary[m].get<double>());
      double mean = 0.0, var = 0.0;
      for (double x : v) mean += x / v.size();
      for (double x : v) var += (x - mean) * (x - mean);
      // No run: no mean; one run: no spread (null, not 0).
      point[m] = v.empty() ? nlohmann::json() : nlohmann::json(mean);
      point[m + "_sd"] =
          v.size() > 1 ? nlohmann::json(std::sqrt(var / (v.size() - 1))) : nlohmann::json();
      point[m + "_n"] = v.size();
    }
    point_list.push_back(point);
  }
  return point_list;
}

nlohmann::json SweepAggregates(const std::vector<SweepAxis>& axes,
                               const std::vector<SweepRunReport>& runs) {
  nlohmann::json aggregates = {{"points", SweepPoints(axes, runs)},
                               {"point_columns", SweepPointColumns(axes)}};
  const std::vector<std::size_t> point_axes = PointAxes(axes);
  if (point_axes.size() != 1 || axes[point_axes[0]].field != "bed.thickness_m") return aggregates;
  // Hc once the sweep has ended: the thin beds run first, and a range cut short may look flat.
  const auto pending = std::count_if(runs.begin(), runs.end(), [](const SweepRunReport& run) {
    return run.state == "queued" || run.state == "preparing_bed" || run.state == "running";
  });
  if (pending > 0) {
    aggregates["Hc_m"] = nullptr;
    aggregates["critical_thickness"] = {
        {"Hc_m", nullptr},
        {"reached", false},
        {"pending_runs", pending},
        {"note", "Hc when the sweep has ended: " + std::to_string(pending) + " of " +
                     std::to_string(runs.size()) + " runs still to come"}};
    return aggregates;
  }
  std::vector<std::pair<double, double>> h_to_p;
  for (const nlohmann::json& point : aggregates["points"])
    if (point["bed.thickness_m"].is_number() && point["P_N"].is_number())
      h_to_p.push_back({point["bed.thickness_m"].get<double>(), point["P_N"].get<double>()});
  std::sort(h_to_p.begin(), h_to_p.end());
  const nlohmann::json hc = CriticalThickness(h_to_p);
  if (!hc.is_null()) {
    aggregates["Hc_m"] = hc["Hc_m"];
    aggregates["critical_thickness"] = hc;
  }
  return aggregates;
}

nlohmann::json WriteSweepReport(const std::filesystem::path& dir,
                                const std::vector<SweepAxis>& axes,
                                const std::vector<SweepRunReport>& runs,
                                const nlohmann::json& extra, std::FILE* table) {
  std::filesystem::create_directories(dir);
  // sweep.csv: one row per run.
  std::ofstream csv(dir / sweep_files::kTable);
  csv << "run,id";
  for (const auto& axis : axes) csv << "," << axis.field;
  csv << ",status";
  for (const auto& m : SweepMetricNames()) csv << "," << m;
  csv << ",run_dir,error\n";
  int failed = 0;
  for (std::size_t j = 0; j < runs.size(); ++j) {
    const SweepRunReport& r = runs[j];
    csv << j << ",";
    if (r.id != 0) csv << r.id;
    for (const auto& v : r.values) csv << "," << CsvCell(v);
    csv << "," << RunStatus(r);
    // Every cell as points.csv's: numbers exact, a text quoted where it must be.
    for (const auto& m : SweepMetricNames())
      csv << ","
          << (r.ok && r.summary.contains(m) && r.summary[m].is_number() ? CsvCell(r.summary[m])
                                                                        : "");
    csv << "," << CsvCell("runs/" + r.name) << "," << CsvCell(r.error) << "\n";
    failed += !r.ok;
  }

  const nlohmann::json aggregates = SweepAggregates(axes, runs);
  // points.csv: the points' records, one row each (what the plots read).
  const std::vector<std::string> columns = SweepPointColumns(axes);
  std::ofstream points_csv(dir / sweep_files::kPoints);
  for (std::size_t c = 0; c < columns.size(); ++c) points_csv << (c ? "," : "") << columns[c];
  points_csv << "\n";
  for (const nlohmann::json& point : aggregates["points"]) {
    for (std::size_t c = 0; c < columns.size(); ++c)
      points_csv << (c ? "," : "") << CsvCell(point[columns[c]]);
    points_csv << "\n";
  }
  if (table) PrintPoints(axes, aggregates["points"], table);

  nlohmann::json summary = {
      {"runs", runs.size()},
      {"failed", failed},
      {"axes", nlohmann::json::array()},
      {"points", aggregates["points"]},
      {"point_columns", aggregates["point_columns"]},
  };
  summary.update(extra);
  for (const auto& axis : axes)
    summary["axes"].push_back({{"field", axis.field}, {"values", SweepValuesJson(axis.values)}});
  // Hc of the points, unless the sweep found its own (--find-hc).
  if (aggregates.contains("critical_thickness") && !summary.contains("critical_thickness")) {
    summary["Hc_m"] = aggregates["Hc_m"];
    summary["critical_thickness"] = aggregates["critical_thickness"];
  }
  if (summary.contains("critical_thickness")) {
    const nlohmann::json& hc = summary["critical_thickness"];
    if (hc.value("reached", false))
      std::fprintf(table, "critical thickness Hc = %.2f cm (plateau P = %.4g N)\n",
                   100 * hc["Hc_m"].get<double>(), hc["plateau_P_N"].get<double>());
    else if (hc.contains("note"))
      std::fprintf(table, "%s\n", hc["note"].get<std::string>().c_str());
  }
  report::WriteFileAtomically(dir / sweep_files::kSummary, summary.dump(2) + "\n");
  return summary;
}

std::size_t WriteSweepLongTable(const std::filesystem::path& dir,
                                const std::vector<SweepAxis>& axes,
                                const std::vector<SweepRunReport>& runs) {
  const std::filesystem::path path = dir / sweep_files::kLong;
  const std::filesystem::path partial = path.string() + ".partial";
  std::ofstream out(partial, std::ios::trunc);
  std::string columns;  // plate_force.csv's header: the first run's, every run's
  std::size_t rows = 0;
  for (std::size_t j = 0; j < runs.size(); ++j) {
    const SweepRunReport& r = runs[j];
    if (!r.ok) continue;
    const std::filesystem::path series =
        dir / sweep_files::kRuns / r.name / report::run_files::kPlateForce;
    std::ifstream in(series);
    std::string line;
    if (!in || !std::getline(in, line))
      throw std::runtime_error("cannot read " + series.string() + " for " + path.string());
    if (columns.empty()) {
      columns = line;
      out << "run";
      for (const SweepAxis& axis : axes) out << "," << CsvCell(axis.field);
      out << "," << columns << "\n";
    } else if (line != columns) {
      throw std::runtime_error(series.string() + " has the columns \"" + line + "\", not \"" +
                               columns + "\" as the sweep's other runs");
    }
    std::string prefix = std::to_string(j);
    for (const std::string& v : r.values) prefix += "," + CsvCell(v);
    while (std::getline(in, line)) {
      if (line.empty()) continue;
      out << prefix << "," << line << "\n";
      ++rows;
    }
  }
  out.close();
  if (!out) throw std::runtime_error("cannot write " + path.string());
  std::filesystem::rename(partial, path);
  return rows;
}

}  // namespace dembuf
