#include "sweep.h"

#include <omp.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>

#include "dembuf/engine/errors.h"
#include "dembuf/engine/impact.h"
#include "dembuf/engine/scene_fields.h"
#include "run_output.h"

namespace dembuf::cli {

namespace {

std::string NumberText(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.12g", v);
  return buf;
}

double ParseNumber(const std::string& field, const std::string& text) {
  try {
    std::size_t used = 0;
    const double v = std::stod(text, &used);
    if (used == text.size() && std::isfinite(v)) return v;
  } catch (const std::exception&) {
  }
  throw SceneError(field, "\"" + text + "\" is not a number in the --vary range");
}

// The summary fields a sweep tabulates, in column order.
const std::vector<std::string>& MetricNames() {
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

struct Job {
  std::size_t index;
  std::vector<std::string> values;  // one per axis
  Scene scene;
  std::string source_hash;
};

struct JobResult {
  bool ok = false;
  std::string error;
  nlohmann::json summary;
};

std::string JobName(const Job& job, const std::vector<SweepAxis>& axes) {
  char buf[16];
  std::snprintf(buf, sizeof buf, "%03zu", job.index);
  std::string name = buf;
  for (std::size_t a = 0; a < axes.size(); ++a) {
    std::string field = axes[a].field.substr(axes[a].field.rfind('.') + 1);
    name += "_" + field + "=" + job.values[a];
  }
  return name;
}

// Hc: the plateau is the mean P of the points in the upper half of the thickness range; Hc is
// the smallest thickness from which every point's mean P stays within 10% of the plateau.
nlohmann::json CriticalThickness(const std::vector<std::pair<double, double>>& h_to_p) {
  if (h_to_p.size() < 3) return nullptr;
  const double h_max = h_to_p.back().first;
  double plateau = 0.0;
  int count = 0;
  for (const auto& [h, p] : h_to_p)
    if (h >= 0.5 * h_max) {
      plateau += p;
      ++count;
    }
  plateau /= count;
  double hc = h_max;
  for (auto it = h_to_p.rbegin(); it != h_to_p.rend(); ++it) {
    if (it->second > 1.10 * plateau) break;
    hc = it->first;
  }
  return {{"Hc_m", hc},
          {"plateau_P_N", plateau},
          {"rule",
           "smallest H from which mean P stays within 10% of the mean P over the upper "
           "half of the H range"}};
}

}  // namespace

SweepAxis ParseVary(const std::string& spec) {
  const auto eq = spec.find('=');
  if (eq == std::string::npos || eq == 0)
    throw SceneError("", "--vary \"" + spec +
                             "\" must be dotted.field=START:STOP:STEP or dotted.field=v1,v2,...");
  SweepAxis axis;
  axis.field = spec.substr(0, eq);
  const std::string rest = spec.substr(eq + 1);
  if (std::count(rest.begin(), rest.end(), ':') == 2) {
    const auto c1 = rest.find(':'), c2 = rest.rfind(':');
    const double start = ParseNumber(axis.field, rest.substr(0, c1));
    const double stop = ParseNumber(axis.field, rest.substr(c1 + 1, c2 - c1 - 1));
    const double step = ParseNumber(axis.field, rest.substr(c2 + 1));
    if (!(step > 0.0) || stop < start)
      throw SceneError(axis.field, "range " + rest + " needs STEP > 0 and STOP >= START");
    const auto count = static_cast<long>(std::floor((stop - start) / step + 1e-9)) + 1;
    if (count > 10000) throw SceneError(axis.field, "range " + rest + " has over 10000 values");
    for (long k = 0; k < count; ++k) axis.values.push_back(NumberText(start + k * step));
  } else {
    std::size_t begin = 0;
    while (begin <= rest.size()) {
      const auto comma = rest.find(',', begin);
      const std::string item =
          rest.substr(begin, comma == std::string::npos ? std::string::npos : comma - begin);
      if (item.empty()) throw SceneError(axis.field, "empty value in --vary list \"" + rest + "\"");
      axis.values.push_back(item);
      if (comma == std::string::npos) break;
      begin = comma + 1;
    }
  }
  // Every value must be valid for the field before anything runs.
  Scene probe;
  for (const std::string& v : axis.values) SetSceneField(probe, axis.field, v);
  return axis;
}

int RunSweep(const Scene& base, const SweepOptions& options, BedCache& beds) {
  std::vector<SweepAxis> axes = options.axes;
  const bool seeds_varied = std::any_of(axes.begin(), axes.end(),
                                        [](const SweepAxis& a) { return a.field == "bed.seed"; });
  if (!seeds_varied) {
    SweepAxis seed{"bed.seed", {}};
    for (int s = 1; s <= options.seeds; ++s) seed.values.push_back(std::to_string(s));
    axes.push_back(seed);
  }

  // The product of the axes; every scene is checked before the first run starts.
  std::vector<Job> jobs;
  std::vector<std::size_t> pick(axes.size(), 0);
  while (true) {
    Job job;
    job.index = jobs.size();
    job.scene = base;
    for (std::size_t a = 0; a < axes.size(); ++a) {
      job.values.push_back(axes[a].values[pick[a]]);
      SetSceneField(job.scene, axes[a].field, job.values.back());
    }
    ValidateScene(job.scene);
    job.source_hash = BedSourceHash(job.scene);
    jobs.push_back(std::move(job));
    std::size_t a = 0;
    while (a < axes.size() && ++pick[a] == axes[a].values.size()) pick[a++] = 0;
    if (a == axes.size()) break;
  }

  // Run order: round robin over the source beds, so that parallel workers start by settling
  // different beds instead of waiting for the same one.
  std::map<std::string, std::vector<std::size_t>> by_source;
  for (const Job& job : jobs) by_source[job.source_hash].push_back(job.index);
  std::vector<std::size_t> order;
  for (std::size_t round = 0; order.size() < jobs.size(); ++round)
    for (const auto& [hash, list] : by_source)
      if (round < list.size()) order.push_back(list[round]);

  std::filesystem::create_directories(options.out_dir / "runs");
  std::vector<JobResult> results(jobs.size());
  std::atomic<int> finished{0};
  std::mutex print_mutex;
  const auto sweep_start = std::chrono::steady_clock::now();
  std::printf("sweep: %zu runs (%zu source beds), %d at a time, into %s\n", jobs.size(),
              by_source.size() - by_source.count(""), options.jobs, options.out_dir.c_str());
  std::fflush(stdout);

#pragma omp parallel for schedule(dynamic) num_threads(options.jobs)
  for (std::size_t k = 0; k < order.size(); ++k) {
    const Job& job = jobs[order[k]];
    const std::filesystem::path dir = options.out_dir / "runs" / JobName(job, axes);
    JobResult& result = results[job.index];
    // A run finished by an earlier, interrupted invocation of the same sweep is kept: its
    // summary records its scene, and only an identical scene counts.
    if (std::ifstream previous{dir / "summary.json"}) {
      try {
        nlohmann::json done = nlohmann::json::parse(previous);
        if (done["scene"] == SceneToJson(job.scene)) {
          result.summary = std::move(done);
          result.ok = true;
          std::lock_guard lock(print_mutex);
          std::printf("[%d/%zu] %s: done earlier, kept\n", ++finished, jobs.size(),
                      JobName(job, axes).c_str());
          continue;
        }
      } catch (const std::exception&) {
        // unreadable: run it again
      }
    }
    auto last_report = std::chrono::steady_clock::now();
    const auto job_start = last_report;
    BedRequest bed_request;
    bed_request.on_progress = [&](const BedProgress& p) {
      const auto now = std::chrono::steady_clock::now();
      if (now - last_report < std::chrono::seconds(30)) return;
      last_report = now;
      std::lock_guard lock(print_mutex);
      std::printf("  run %zu: %s, %zu beads, t = %.0f ms, kinetic %.2g m g d, balance %.2g%%\n",
                  job.index, p.stage.c_str(), p.beads, p.t_s * 1e3, p.kinetic_ratio,
                  100 * p.balance_error);
      std::fflush(stdout);
    };
    try {
      std::filesystem::create_directories(dir);
      SampleCsvWriter csv(dir / "plate_force.csv");
      RunControl control;
      control.beds = &beds;
      control.bed_request = &bed_request;
      control.on_sample = [&](const ImpactSample& s) { csv.Write(s); };
      const ImpactSummary summary = RunImpact(job.scene, control);
      csv.Commit();
      result.summary = SummaryToJson(summary, job.scene);
      WriteFileAtomically(dir / "summary.json", result.summary.dump(2) + "\n");
      result.ok = true;
    } catch (const std::exception& e) {
      result.error = e.what();
    }
    std::lock_guard lock(print_mutex);
    const int done = ++finished;
    std::printf("[%d/%zu] %s: ", done, jobs.size(), JobName(job, axes).c_str());
    if (result.ok) {
      std::printf(
          "P = %.4g N, lambda = %.1f%%, H = %.2f cm, C0 = %.3f (%.0f s with the bed)\n",
          result.summary["P_N"].get<double>(), 100 * result.summary["lambda"].get<double>(),
          100 * result.summary["bed_thickness_m"].get<double>(), result.summary["C0"].get<double>(),
          std::chrono::duration<double>(std::chrono::steady_clock::now() - job_start).count());
    } else {
      std::printf("FAILED: %s\n", result.error.c_str());
    }
    std::fflush(stdout);
  }

  // sweep.csv: one row per run.
  std::ofstream csv(options.out_dir / "sweep.csv");
  csv << "job";
  for (const auto& axis : axes) csv << "," << axis.field;
  csv << ",status";
  for (const auto& m : MetricNames()) csv << "," << m;
  csv << ",run_dir,error\n";
  csv.precision(10);
  int failed = 0;
  for (const Job& job : jobs) {
    const JobResult& r = results[job.index];
    csv << job.index;
    for (const auto& v : job.values) csv << "," << v;
    csv << "," << (r.ok ? "ok" : "failed");
    for (const auto& m : MetricNames()) {
      csv << ",";
      if (r.ok && r.summary.contains(m) && r.summary[m].is_number())
        csv << r.summary[m].get<double>();
    }
    std::string error = r.error;
    std::replace(error.begin(), error.end(), '"', '\'');
    csv << ",runs/" << JobName(job, axes) << ",\"" << error << "\"\n";
    failed += !r.ok;
  }

  // Points: the runs that differ only in their seed, with mean and sample standard deviation.
  std::map<std::vector<std::string>, std::vector<std::size_t>> points;
  std::vector<std::size_t> point_axes;
  for (std::size_t a = 0; a < axes.size(); ++a)
    if (axes[a].field != "bed.seed") point_axes.push_back(a);
  for (const Job& job : jobs) {
    std::vector<std::string> key;
    for (std::size_t a : point_axes) key.push_back(job.values[a]);
    points[key].push_back(job.index);
  }
  nlohmann::json point_list = nlohmann::json::array();
  std::vector<std::pair<double, double>> h_to_p;
  // points.csv: one row per point, each metric's mean, sd and n (what the plots read).
  std::ofstream points_csv(options.out_dir / "points.csv");
  points_csv.precision(10);
  for (std::size_t k = 0; k < point_axes.size(); ++k)
    points_csv << (k ? "," : "") << axes[point_axes[k]].field;
  for (const auto& m : MetricNames()) points_csv << "," << m << "," << m << "_sd," << m << "_n";
  points_csv << "\n";
  std::printf("\n");
  for (std::size_t a : point_axes) std::printf("%-22s", axes[a].field.c_str());
  std::printf("%4s %22s %18s %16s %8s\n", "n", "P [N] mean +- sd", "lambda [%]", "crater [cm]",
              "C0");
  for (const auto& [key, members] : points) {
    nlohmann::json point;
    for (std::size_t k = 0; k < point_axes.size(); ++k) point[axes[point_axes[k]].field] = key[k];
    std::map<std::string, std::pair<double, double>> stats;  // mean, sd
    for (const auto& m : MetricNames()) {
      std::vector<double> v;
      for (std::size_t j : members)
        if (results[j].ok && results[j].summary[m].is_number())
          v.push_back(results[j].summary[m].get<double>());
      if (v.empty()) continue;
      double mean = 0.0, var = 0.0;
      for (double x : v) mean += x / v.size();
      for (double x : v) var += (x - mean) * (x - mean);
      const double sd = v.size() > 1 ? std::sqrt(var / (v.size() - 1)) : 0.0;
      point[m] = {{"mean", mean}, {"sd", sd}, {"n", v.size()}};
      stats[m] = {mean, sd};
    }
    point_list.push_back(point);
    for (std::size_t k = 0; k < key.size(); ++k) points_csv << (k ? "," : "") << key[k];
    for (const auto& m : MetricNames()) {
      if (stats.count(m)) {
        points_csv << "," << stats[m].first << "," << stats[m].second << ","
                   << point[m]["n"].get<std::size_t>();
      } else {
        points_csv << ",,,0";
      }
    }
    points_csv << "\n";
    for (const auto& k : key) std::printf("%-22s", k.c_str());
    auto ms = [&](const char* m, double scale) {
      char buf[48];
      if (!stats.count(m)) return std::string("-");
      std::snprintf(buf, sizeof buf, "%.4g +- %.2g", stats[m].first * scale,
                    stats[m].second * scale);
      return std::string(buf);
    };
    std::printf(
        "%4zu %22s %18s %16s %8s\n", members.size(), ms("P_N", 1).c_str(),
        ms("lambda", 100).c_str(), ms("crater_depth_m", 100).c_str(),
        stats.count("C0") ? NumberText(std::round(stats["C0"].first * 1000) / 1000).c_str() : "-");
    if (point_axes.size() == 1 && axes[point_axes[0]].field == "bed.thickness_m" &&
        stats.count("P_N"))
      h_to_p.push_back({std::stod(key[0]), stats["P_N"].first});
  }
  std::sort(h_to_p.begin(), h_to_p.end());

  nlohmann::json summary = {
      {"runs", jobs.size()},
      {"failed", failed},
      {"axes", nlohmann::json::array()},
      {"points", point_list},
      {"wall_time_s",
       std::chrono::duration<double>(std::chrono::steady_clock::now() - sweep_start).count()},
      {"beds_prepared", beds.prepared_counts()},
  };
  for (const auto& axis : axes)
    summary["axes"].push_back({{"field", axis.field}, {"values", axis.values}});
  if (!h_to_p.empty()) {
    const nlohmann::json hc = CriticalThickness(h_to_p);
    if (!hc.is_null()) {
      summary["Hc_m"] = hc["Hc_m"];
      summary["critical_thickness"] = hc;
      std::printf("critical thickness Hc = %.2f cm (plateau P = %.4g N)\n",
                  100 * hc["Hc_m"].get<double>(), hc["plateau_P_N"].get<double>());
    }
  }
  WriteFileAtomically(options.out_dir / "summary.json", summary.dump(2) + "\n");
  std::printf("wrote %s and %s (%d failed) in %.0f s\n", (options.out_dir / "sweep.csv").c_str(),
              (options.out_dir / "summary.json").c_str(), failed,
              summary["wall_time_s"].get<double>());
  return failed;
}

}  // namespace dembuf::cli
