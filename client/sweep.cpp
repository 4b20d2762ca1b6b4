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
#include <set>

#include "dembuf/engine/errors.h"
#include "dembuf/engine/impact.h"
#include "dembuf/engine/scene_fields.h"
#include "dembuf/engine/sweep_plan.h"
#include "dembuf/report/run_output.h"
#include "dembuf/report/sweep_report.h"

namespace dembuf::cli {

int RunSweep(const Scene& base, const SweepOptions& options, BedCache& beds) {
  const std::vector<SweepAxis> axes = WithSeedAxis(options.axes, options.seeds, base.bed.seed);
  // Every scene is checked before the first run starts.
  const std::vector<SweepRun> runs = ExpandSweep(base, axes);
  const std::vector<std::size_t> order = InterleaveBySourceBed(runs);
  std::set<std::string> sources;
  for (const SweepRun& run : runs)
    if (!run.source_hash.empty()) sources.insert(run.source_hash);

  struct RunResult {
    bool ok = false;
    std::string error;
    nlohmann::json summary;
  };
  std::filesystem::create_directories(options.out_dir / "runs");
  std::vector<RunResult> results(runs.size());
  std::atomic<int> finished{0};
  std::mutex print_mutex;
  const auto sweep_start = std::chrono::steady_clock::now();
  std::printf("sweep: %zu runs (%zu source beds), %d at a time, into %s\n", runs.size(),
              sources.size(), options.jobs, options.out_dir.c_str());
  std::fflush(stdout);

#pragma omp parallel for schedule(dynamic) num_threads(options.jobs)
  for (std::size_t k = 0; k < order.size(); ++k) {
    const SweepRun& job = runs[order[k]];
    const std::filesystem::path dir = options.out_dir / "runs" / job.name;
    RunResult& result = results[job.index];
    // A run finished by an earlier, interrupted invocation of the same sweep is kept: its
    // summary records its scene, and only an identical scene counts.
    if (std::ifstream previous{dir / "summary.json"}) {
      try {
        nlohmann::json done = nlohmann::json::parse(previous);
        if (done["scene"] == report::SceneToJson(job.scene)) {
          result.summary = std::move(done);
          result.ok = true;
          std::lock_guard lock(print_mutex);
          std::printf("[%d/%zu] %s: done earlier, kept\n", ++finished, runs.size(),
                      job.name.c_str());
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
      report::SampleCsvWriter csv(dir / "plate_force.csv");
      RunControl control;
      control.beds = &beds;
      control.bed_request = &bed_request;
      control.on_sample = [&](const ImpactSample& s) { csv.Write(s); };
      const ImpactSummary summary = RunImpact(job.scene, control);
      csv.Commit();
      result.summary = report::SummaryToJson(summary, job.scene);
      report::WriteFileAtomically(dir / "summary.json", result.summary.dump(2) + "\n");
      result.ok = true;
    } catch (const std::exception& e) {
      result.error = e.what();
    }
    std::lock_guard lock(print_mutex);
    const int done = ++finished;
    std::printf("[%d/%zu] %s: ", done, runs.size(), job.name.c_str());
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

  std::vector<report::SweepRunReport> reports;
  for (std::size_t k = 0; k < runs.size(); ++k)
    reports.push_back(
        {runs[k].name, runs[k].values, results[k].ok, results[k].error, results[k].summary});
  const nlohmann::json extra = {
      {"wall_time_s",
       std::chrono::duration<double>(std::chrono::steady_clock::now() - sweep_start).count()},
      {"beds_prepared", beds.prepared_counts()},
  };
  const nlohmann::json summary =
      report::WriteSweepReport(options.out_dir, axes, reports, extra, stdout);
  const int failed = summary["failed"].get<int>();
  std::printf("wrote %s and %s (%d failed) in %.0f s\n", (options.out_dir / "sweep.csv").c_str(),
              (options.out_dir / "summary.json").c_str(), failed,
              summary["wall_time_s"].get<double>());
  return failed;
}

}  // namespace dembuf::cli
