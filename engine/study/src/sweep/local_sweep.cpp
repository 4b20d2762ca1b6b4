#include "dembuf/study/sweep/local_sweep.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <fstream>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>

#include "dembuf/core/threads.h"
#include "dembuf/study/bed/bed.h"
#include "dembuf/study/files/own_files.h"
#include "dembuf/study/files/provenance.h"
#include "dembuf/study/files/run_output.h"
#include "dembuf/study/impact/impact.h"
#include "dembuf/study/run/folder_recorder.h"
#include "dembuf/study/scene/errors.h"
#include "dembuf/study/scene/scene_fields.h"
#include "dembuf/study/sweep/run_queue.h"
#include "dembuf/study/sweep/schedule.h"
#include "dembuf/study/sweep/sweep_plan.h"
#include "dembuf/study/sweep/sweep_report.h"

namespace dembuf {

namespace {

// A line (or part of one) for people, on `out` when there is one.
[[gnu::format(printf, 2, 3)]] void Say(std::FILE* out, const char* format, ...) {
  if (!out) return;
  va_list args;
  va_start(args, format);
  std::vfprintf(out, format, args);
  va_end(args);
}

void Flush(std::FILE* out) {
  if (out) std::fflush(out);
}

struct RunResult {
  bool ok = false;
  bool interrupted = false;
  std::string error;
  nlohmann::json summary;
  std::string folder;  ///< the folder of runs/ it is in (its name, unless kept from another)
};

namespace fs = std::filesystem;

// The folders of runs/ that are this account's own (own_files.h: no links, none another
// account put there), by name.
std::vector<std::string> RunFolders(const fs::path& runs) {
  std::vector<std::string> names;
  std::error_code error;
  for (const fs::directory_entry& entry : fs::directory_iterator(runs, error))
    if (entry.symlink_status().type() == fs::file_type::directory &&
        report::ForeignPathProblem(entry.path(), true).empty())
      names.push_back(entry.path().filename().string());
  std::sort(names.begin(), names.end());
  return names;
}

// The most a run's summary.json or scene.toml read back may hold (some kilobytes each).
constexpr std::size_t kMaxRunFileBytes = 16 << 20;

// A finished run's summary in `dir`, or null (none, not readable as one, or not this
// account's own file in its own folder).
nlohmann::json FinishedSummary(const fs::path& dir) {
  if (!report::ForeignPathProblem(dir, true).empty()) return nullptr;
  const std::optional<std::string> text =
      report::ReadOwnFile(dir / report::run_files::kSummary, kMaxRunFileBytes);
  if (!text) return nullptr;
  nlohmann::json summary = nlohmann::json::parse(*text, nullptr, false);
  if (!summary.is_object() || !summary.contains("scene")) return nullptr;
  // A run of an earlier dembuf names its measured height bed_thickness_m.
  if (!summary.contains("measured_thickness_m") && summary.contains("bed_thickness_m"))
    summary["measured_thickness_m"] = report::MeasuredThickness(summary);
  return summary;
}

// Why an earlier run's summary cannot stand for a run of `scene` now ("" : it can): a result
// of another build of dembuf (its bits may differ), of another scene, or of another bed (an
// imported bed file changed since: its key is of the file's content).
std::string WhyNotKept(const nlohmann::json& summary, const Scene& scene) {
  // (The names only: a build of unknown commit resumes its own sweeps.)
  if (!report::MadeByThisEngine(summary, report::BuildMatch::kSameNames))
    return "made by another build of dembuf";
  if (!report::RanScene(summary, report::SceneText(scene))) return "its scene is another";
  const bool has_bed = !scene.bed.import.empty() || scene.bed.thickness_m > 0.0;
  std::string bed;
  try {
    bed = has_bed ? BedHash(scene) : "";
  } catch (const std::exception& e) {
    return std::string("its bed cannot be checked: ") + e.what();
  }
  const nlohmann::json& provenance = summary["provenance"];
  const auto held = provenance.find("bed_hash");
  if (held == provenance.end() || !held->is_string() || held->get<std::string>() != bed)
    return "its bed is another";
  return "";
}

// The runs of one sweep, run by the workers of one queue, each into its folder of runs/.
class SweepRunner {
 public:
  SweepRunner(const SweepOptions& options, BedCache& beds, const std::vector<SweepRun>& runs)
      : m_options(options), m_beds(beds), m_runs(runs), m_results(runs.size()) {
    // The finished runs already in the folder, by their scene: a run is kept wherever an
    // earlier invocation of the sweep put it (another point list numbers its runs otherwise).
    for (const std::string& name : RunFolders(options.out_dir / sweep_files::kRuns))
      if (nlohmann::json done = FinishedSummary(options.out_dir / sweep_files::kRuns / name);
          !done.is_null())
        m_finished_by_scene.emplace(done["scene"].dump(), name);
  }
  /// Runs every run, options.jobs at a time.
  void RunAll();
  const std::vector<RunResult>& results() const { return m_results; }

 private:
  void RunOne(const SweepRun& job, const std::atomic<int>* threads);
  // A run finished by an earlier invocation of the same sweep is kept: its summary records
  // its scene, and only an identical scene counts.
  bool KeptFromEarlier(const SweepRun& job, RunResult& result);
  void PrintEnd(const SweepRun& job, const RunResult& result,
                std::chrono::steady_clock::time_point start);
  // Notes what run `index` is doing; every status_interval_s one line on options.status says
  // how far the sweep is and what each running run does.
  void Report(std::size_t index, std::string doing);

  const SweepOptions& m_options;
  BedCache& m_beds;
  const std::vector<SweepRun>& m_runs;
  std::vector<RunResult> m_results;
  std::atomic<int> m_finished{0};
  std::mutex m_print_mutex;
  std::map<std::size_t, std::string> m_doing;              ///< what each running run does
  std::map<std::string, std::string> m_finished_by_scene;  ///< scene JSON -> folder name
  std::chrono::steady_clock::time_point m_last_report = std::chrono::steady_clock::now();
};

void SweepRunner::Report(std::size_t index, std::string doing) {
  std::lock_guard lock(m_print_mutex);
  if (doing.empty())
    m_doing.erase(index);
  else
    m_doing[index] = std::move(doing);
  const auto now = std::chrono::steady_clock::now();
  std::FILE* status = m_options.status;
  if (!status || now - m_last_report < std::chrono::duration<double>(m_options.status_interval_s))
    return;
  m_last_report = now;
  std::fprintf(status, "sweep: %d of %zu runs done", m_finished.load(), m_runs.size());
  for (const auto& [run, what] : m_doing) std::fprintf(status, "; run %zu: %s", run, what.c_str());
  std::fprintf(status, "\n");
}

bool SweepRunner::KeptFromEarlier(const SweepRun& job, RunResult& result) {
  const auto found = m_finished_by_scene.find(report::SceneToJson(job.scene).dump());
  if (found == m_finished_by_scene.end()) return false;
  result.summary = FinishedSummary(m_options.out_dir / sweep_files::kRuns / found->second);
  if (result.summary.is_null()) return false;  // gone since: run it again
  if (const std::string why = WhyNotKept(result.summary, job.scene); !why.empty()) {
    result.summary = nullptr;
    std::lock_guard lock(m_print_mutex);
    Say(m_options.report, "%s: the run in runs/%s is not kept (%s): running it again\n",
        job.name.c_str(), found->second.c_str(), why.c_str());
    return false;
  }
  result.ok = true;
  result.folder = found->second;
  std::lock_guard lock(m_print_mutex);
  Say(m_options.report, "[%d/%zu] %s: done earlier, kept%s%s\n", ++m_finished, m_runs.size(),
      job.name.c_str(), found->second == job.name ? "" : " in ",
      found->second == job.name ? "" : found->second.c_str());
  return true;
}

void SweepRunner::RunOne(const SweepRun& job, const std::atomic<int>* threads) {
  const std::filesystem::path dir = m_options.out_dir / sweep_files::kRuns / job.name;
  RunResult& result = m_results[job.index];
  if (KeptFromEarlier(job, result)) return;
  result.folder = job.name;
  const auto job_start = std::chrono::steady_clock::now();
  char text[160];
  auto bed_progress = [&](const BedProgress& p) {
    std::snprintf(text, sizeof text, "%s, %zu beads, t = %.0f ms, %d threads", p.stage.c_str(),
                  p.beads, p.t_s * 1e3, threads->load());
    Report(job.index, text);
  };
  auto impact_progress = [&](const ImpactProgress& p) {
    std::snprintf(text, sizeof text, "impact, %.1f of %.1f ms, %d threads", p.t_s * 1e3,
                  p.t_end_estimate_s * 1e3, threads->load());
    Report(job.index, text);
  };
  try {
    // Never written through a link or into a folder another account may have put there; an
    // older dembuf's folder of this point open to the group is made anew, closed.
    if (report::OwnFolderOpenToOthers(dir)) fs::remove_all(dir);
    if (const std::string problem = report::ForeignPathProblem(dir, true); !problem.empty())
      throw std::runtime_error(dir.string() + " is " + problem +
                               ": not written into; choose another --out");
    report::RemoveRunOutputs(dir);  // what an interrupted run of this point left
    FolderRecorder recorder(dir, job.scene);
    JobControl control;
    control.context = report::RunStartingNow(m_options.command_line);
    control.steering.cancel = m_options.cancel;
    control.steering.threads = threads;
    control.steering.on_progress = impact_progress;
    control.on_bed_progress = bed_progress;
    const ImpactSummary summary = RunJob(job.scene, m_beds, control, recorder);
    if (m_options.on_run_done) m_options.on_run_done(job, summary);
    result.summary = recorder.summary_json();
    result.ok = true;
  } catch (const Cancelled&) {
    result.interrupted = true;
    result.error = "interrupted";
  } catch (const std::exception& e) {
    result.error = e.what();
  }
  Report(job.index, "");
  if (!result.interrupted) PrintEnd(job, result, job_start);
}

void SweepRunner::PrintEnd(const SweepRun& job, const RunResult& result,
                           std::chrono::steady_clock::time_point start) {
  std::lock_guard lock(m_print_mutex);
  Say(m_options.report, "[%d/%zu] %s: ", ++m_finished, m_runs.size(), job.name.c_str());
  if (result.ok) {
    const nlohmann::json& s = result.summary;
    Say(m_options.report,
        "P = %.4g N, lambda = %.1f%%, H = %.2f cm, C0 = %.3f (%.0f s with the bed)\n",
        s["P_N"].get<double>(), 100 * s["lambda"].get<double>(),
        100 * s["measured_thickness_m"].get<double>(), s["C0"].get<double>(),
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  } else {
    Say(m_options.report, "FAILED: %s\n", result.error.c_str());
  }
  Flush(m_options.report);
}

// The daemon's queue and rule: runs in the schedule's order, a run that would only wait for a
// bed another worker prepares passed over, the cores shared by what each run can use.
void SweepRunner::RunAll() {
  const int jobs = m_options.jobs;
  // The CPUs this process may use (dem::UsableCpus), whatever --jobs says: runs beyond them
  // wait for a core.
  RunQueue queue(m_beds, dem::UsableCpus(), m_options.cancel);
  m_beds.OnPrepared([&](const PreparedBed& bed) {
    if (m_options.on_bed_prepared) m_options.on_bed_prepared(bed);
    queue.Wake();
  });
  // The runs that prepare a source bed first, then the heaviest (schedule.h).
  const std::vector<RunLoad> loads = LoadsOf(m_runs, &m_beds);
  for (const std::size_t k : StartOrder(loads))
    queue.Push(static_cast<RunQueue::Id>(k), {m_runs[k].beds, loads[k]});
  queue.Close();
  std::vector<std::atomic<int>> worker_threads(jobs);
  for (std::atomic<int>& t : worker_threads) t = 1;
  QueueWorkers::Work work;
  work.start = [&](RunQueue::Id, int worker) { return &worker_threads[worker]; };
  work.run = [&](RunQueue::Id id, int, const std::atomic<int>* threads) {
    RunOne(m_runs[static_cast<std::size_t>(id)], threads);  // it catches what a run throws
    return QueueWorkers::RunEnd::kDone;
  };
  // Engine parts that are not lent cores (the bare-plate run) use one thread.
  work.omp_threads = 1;
  QueueWorkers workers(queue, jobs, std::move(work));
  workers.Join();
  m_beds.OnPrepared({});
}

// A run's values of the axes, as the field table writes them (so that a point asked for as
// 0.01 and as 1e-2 is one point; CanonicalSweepValue gives a fetched sweep's the same).
std::vector<std::string> AxisValues(const Scene& scene, const std::vector<SweepAxis>& axes) {
  std::vector<std::string> values;
  for (const SweepAxis& axis : axes)
    values.push_back(FormatSceneField(scene, RequireSceneField(axis.field)));
  return values;
}

// The report files a sweep writes into its folder, besides runs/.
constexpr const char* kSweepReportFiles[] = {sweep_files::kTable, sweep_files::kPoints,
                                             sweep_files::kSummary, sweep_files::kIncomplete};

}  // namespace

nlohmann::json SweepFolderKey(const Scene& base, const std::vector<std::string>& varied_fields) {
  std::set<std::string> varied(varied_fields.begin(), varied_fields.end());
  varied.erase("bed.seed");
  nlohmann::json fields = nlohmann::json::object();
  for (const SceneField& field : SceneFields())
    if (field.name != "bed.seed" && !varied.count(std::string(field.name)))
      fields[std::string(field.name)] = FormatSceneField(base, field);
  return {{"varies", varied}, {"fields", fields}};
}

namespace {

// How `held` (a folder's record) differs from `key`, in a sentence ("" : the same sweep). A
// field the record lacks (one added since it was written) had its default.
std::string KeyDifference(const nlohmann::json& held, const nlohmann::json& key) {
  if (!held.is_object() || !held.contains("varies") || !held["fields"].is_object())
    return std::string(sweep_files::kKey) + " is not a sweep's record";
  if (held["varies"] != key["varies"])
    return "a sweep that varies " + held["varies"].dump() + "; this one varies " +
           key["varies"].dump();
  std::vector<std::string> differ;
  for (const auto& [name, value] : key["fields"].items()) {
    const SceneField* field = FindSceneField(name);
    const nlohmann::json there =
        held["fields"].contains(name)
            ? held["fields"][name]
            : nlohmann::json(field ? FormatSceneField(Scene{}, *field) : std::string("(absent)"));
    if (there != value)
      differ.push_back(name + " = " +
                       (there.is_string() ? there.get<std::string>() : there.dump()) + " there, " +
                       value.get<std::string>() + " here");
  }
  if (differ.empty()) return "";
  std::string text = "a sweep of another scene: " + differ[0];
  if (differ.size() > 1)
    text += " (and " + std::to_string(differ.size() - 1) + " more field" +
            (differ.size() > 2 ? "s" : "") + ")";
  return text;
}

}  // namespace

// What makes `dir` (a sweep's folder) or its runs/ no place for a sweep's results ("" when
// they may be used): another account may write there (own_files.h).
std::string SweepFolderProblem(const fs::path& dir) {
  if (const std::string problem = report::OpenAncestorProblem(dir); !problem.empty())
    return problem + ": another account could swap " + dir.string() +
           " for a link while the sweep writes; choose an --out under folders only you (or "
           "root) may write, or a shared folder with the sticky bit";
  for (const fs::path& folder : {dir, dir / sweep_files::kRuns}) {
    const std::string problem = folder == dir ? report::ForeignSweepFolderProblem(folder)
                                              : report::ForeignPathProblem(folder, true);
    if (!problem.empty())
      return folder.string() + " is " + problem +
             ": another account could change the sweep's results there; choose another --out" +
             (problem.rfind("writable", 0) == 0 ? " (or, if it is yours, chmod go-w it)" : "");
  }
  return "";
}

std::optional<std::string> ClaimSweepFolder(const fs::path& dir, const nlohmann::json& key,
                                            bool force) {
  const report::ClosedToOthersWriting closed;
  if (std::string problem = SweepFolderProblem(dir); !problem.empty()) return problem;
  std::error_code made;
  fs::create_directories(dir / sweep_files::kRuns, made);
  // Closed also where a default ACL opened what was made.
  for (const fs::path& folder : {dir, dir / sweep_files::kRuns})
    if (report::OwnFolderOpenToOthers(folder)) report::CloseToOthersWriting(folder);
  if (std::string problem = SweepFolderProblem(dir); !problem.empty()) return problem;
  const fs::path key_file = dir / sweep_files::kKey;
  std::string refusal;
  if (const std::optional<std::string> held = report::ReadOwnFile(key_file, kMaxRunFileBytes)) {
    const std::string difference = KeyDifference(nlohmann::json::parse(*held, nullptr, false), key);
    if (!difference.empty()) refusal = dir.string() + " holds " + difference;
  } else if (fs::exists(fs::symlink_status(key_file))) {
    const std::string problem = report::ForeignPathProblem(key_file, false);
    return key_file.string() + " is " + (problem.empty() ? "too large or unreadable" : problem) +
           ": it cannot say which sweep the folder holds" +
           (problem.rfind("writable", 0) == 0 ? " (chmod go-w it if it is yours)" : "");
  } else {
    // Runs without a record (an older dembuf's sweep): the folder is this sweep's when every
    // run's own scene makes the same record.
    std::vector<std::string> varies = key["varies"];
    for (const std::string& name : RunFolders(dir / sweep_files::kRuns)) {
      const std::string text =
          report::ReadOwnFile(dir / sweep_files::kRuns / name / report::run_files::kScene,
                              kMaxRunFileBytes)
              .value_or("");
      std::string difference = "runs that name no scene (" + name + ")";
      try {
        if (!text.empty())
          difference = KeyDifference(SweepFolderKey(LoadSceneText(text, name), varies), key);
      } catch (const std::exception&) {
      }
      if (!difference.empty()) {
        refusal = dir.string() + " holds " + difference;
        break;
      }
    }
  }
  if (!refusal.empty() && !force)
    return refusal + "; choose another --out, or pass --force to remove its runs first";
  if (!refusal.empty()) {
    // The runs only: a folder in runs/ that no run wrote stays. Runs of this account left open
    // to its group (an older dembuf's) go too; a link or another account's folder is not
    // touched.
    std::error_code error;
    for (const fs::directory_entry& entry : fs::directory_iterator(dir / sweep_files::kRuns, error))
      if ((report::ForeignPathProblem(entry.path(), true).empty() ||
           report::OwnFolderOpenToOthers(entry.path())) &&
          report::IsRunFolder(entry.path()))
        fs::remove_all(entry.path());
    for (const char* name : kSweepReportFiles) fs::remove(dir / name);
  }
  fs::create_directories(dir / sweep_files::kRuns);
  report::WriteFileAtomically(key_file, key.dump(1) + "\n");
  return std::nullopt;
}

int RunSweep(const Scene& base, const SweepOptions& options, BedCache& beds,
             std::vector<SweepRunReport>* reports_out) {
  const report::ClosedToOthersWriting closed;  // (own_files.h: its runs are kept when it resumes)
  const std::vector<SweepAxis> axes = WithSeedAxis(options.axes, options.seeds, base.bed.seed);
  // Every scene is checked before the first run starts.
  const std::vector<SweepRun> runs = ExpandSweep(base, axes, 100000, {}, options.table_columns);
  std::set<std::string> sources;
  for (const SweepRun& run : runs)
    if (!run.beds.source_hash.empty()) sources.insert(run.beds.source_hash);

  std::filesystem::create_directories(options.out_dir / sweep_files::kRuns);
  const auto sweep_start = std::chrono::steady_clock::now();
  Say(options.report, "sweep: %zu runs (%zu source beds), %d at a time, into %s\n", runs.size(),
      sources.size(), options.jobs, options.out_dir.c_str());
  Flush(options.report);
  SweepRunner runner(options, beds, runs);
  runner.RunAll();
  const std::vector<RunResult>& results = runner.results();

  std::vector<SweepRunReport> reports;
  std::set<std::string> reported;
  for (std::size_t k = 0; k < runs.size(); ++k) {
    const std::string folder = results[k].folder.empty() ? runs[k].name : results[k].folder;
    reported.insert(folder);
    SweepRunReport run;
    run.name = folder;
    run.values = AxisValues(runs[k].scene, axes);
    run.ok = results[k].ok;
    run.error = results[k].error;
    run.summary = results[k].summary;
    reports.push_back(std::move(run));
  }
  // The folder's other runs, of points asked for before: its report lists every run there is.
  for (const std::string& name : RunFolders(options.out_dir / sweep_files::kRuns)) {
    if (reported.count(name) || !report::IsRunFolder(options.out_dir / sweep_files::kRuns / name))
      continue;
    SweepRunReport earlier;
    earlier.name = name;
    earlier.summary = FinishedSummary(options.out_dir / sweep_files::kRuns / name);
    earlier.ok = !earlier.summary.is_null();
    Scene scene;
    try {
      const std::optional<std::string> text = report::ReadOwnFile(
          options.out_dir / sweep_files::kRuns / name / report::run_files::kScene,
          kMaxRunFileBytes);
      if (!text) continue;
      scene = LoadSceneText(*text, name);
      earlier.values = AxisValues(scene, axes);
    } catch (const std::exception&) {
      continue;  // not a run of this sweep's: no scene to place it by
    }
    if (!earlier.ok) earlier.error = "not finished (asked for by an earlier invocation)";
    if (const std::string why = earlier.ok ? WhyNotKept(earlier.summary, scene) : "";
        !why.empty()) {
      // Not listed beside this build's runs: its point runs again when it is asked for.
      Say(options.report,
          "runs/%s is left out of the report (%s): ask for its point to run it again\n",
          name.c_str(), why.c_str());
      continue;
    }
    reports.push_back(std::move(earlier));
  }
  const nlohmann::json extra = {
      {"wall_time_s",
       std::chrono::duration<double>(std::chrono::steady_clock::now() - sweep_start).count()},
      {"beds_prepared", beds.prepared_counts()},
  };
  const nlohmann::json summary =
      WriteSweepReport(options.out_dir, DistinctAxes(axes), reports, extra, options.report);
  if (options.long_table)
    Say(options.report, "wrote %s: %zu samples\n", (options.out_dir / sweep_files::kLong).c_str(),
        WriteSweepLongTable(options.out_dir, axes, reports));
  if (reports_out) reports_out->insert(reports_out->end(), reports.begin(), reports.end());
  int interrupted = 0;
  for (const RunResult& r : results) interrupted += r.interrupted || (!r.ok && r.error.empty());
  const int failed = summary["failed"].get<int>() - interrupted;
  Say(options.report, "wrote %s and %s (%d failed) in %.0f s\n",
      (options.out_dir / sweep_files::kTable).c_str(),
      (options.out_dir / sweep_files::kSummary).c_str(), failed,
      summary["wall_time_s"].get<double>());
  return failed;
}

int RunHcSearch(const Scene& base, const SweepOptions& options, const HcSearchOptions& search,
                BedCache& beds) {
  std::vector<SweepRunReport> all;
  std::vector<std::string> thicknesses;
  int failed = 0;
  auto peak_forces_at = [&](double h) {
    char text[32];
    std::snprintf(text, sizeof text, "%.6g", h);
    Say(options.report, "\nHc search: H = %.4g cm\n", 100 * h);
    SweepOptions step = options;
    step.axes = {MakeSweepAxis("bed.thickness_m", {text}, "")};
    step.long_table = false;  // written once, of every step, below
    std::vector<SweepRunReport> reports;
    failed += RunSweep(base, step, beds, &reports);
    if (options.cancel && options.cancel->load()) throw Cancelled();
    thicknesses.push_back(text);
    std::vector<double> p;
    for (const SweepRunReport& r : reports) {
      if (!r.ok)
        throw std::runtime_error("a run at H = " + std::string(text) + " m failed (" + r.error +
                                 "): Hc cannot be bracketed past it");
      p.push_back(r.summary["P_N"].get<double>());
    }
    all.insert(all.end(), reports.begin(), reports.end());
    return p;
  };
  const HcSearchResult hc = FindCriticalThickness(peak_forces_at, search);
  // The report of every run, as one sweep over the thicknesses visited.
  std::sort(thicknesses.begin(), thicknesses.end(),
            [](const std::string& a, const std::string& b) { return std::stod(a) < std::stod(b); });
  const std::vector<SweepAxis> axes = WithSeedAxis(
      {MakeSweepAxis("bed.thickness_m", thicknesses, "")}, options.seeds, base.bed.seed);
  nlohmann::json points = nlohmann::json::array();
  for (const HcPoint& p : hc.points)
    points.push_back({{"H_m", p.h_m}, {"P_N", p.p_N}, {"mean_P_N", p.mean_N}});
  // The search's Hc stands in the report instead of the fixed-grid rule's.
  // Where P has not levelled off in the range, no Hc (null), as the grid rule says.
  const nlohmann::json hc_m = hc.reached ? nlohmann::json(hc.hc_m) : nlohmann::json();
  const nlohmann::json extra = {
      {"Hc_m", hc_m},
      {"critical_thickness",
       {{"Hc_m", hc_m},
        {"reached", hc.reached},
        {"upper_half_change", hc.upper_half_change},
        {"search_ended_m", hc.hc_m},
        {"Hc_sd_m", hc.reached ? nlohmann::json(hc.hc_sd_m) : nlohmann::json()},
        {"seed_scatter_included", hc.seed_scatter_included},
        {"plateau_P_N", hc.plateau_N},
        {"threshold_P_N", hc.threshold_N},
        {"bracket_m", {hc.bracket_low_m, hc.bracket_high_m}},
        {"method", "bisection"},
        {"rule",
         "the thickness where mean P falls to (1 + margin) times the plateau, the mean P "
         "at the deep end of the range, which is a plateau only if P at the first midpoint (the "
         "upper half's start) is within the margin of it"},
        {"margin", search.margin},
        {"range_m", {search.low_m, search.high_m}},
        {"tolerance_m", search.tolerance_m},
        {"note", hc.note},
        {"steps", points}}}};
  Say(options.report, "\nall %zu runs of the search:", all.size());
  WriteSweepReport(options.out_dir, axes, all, extra, options.report);
  if (options.long_table) WriteSweepLongTable(options.out_dir, axes, all);
  if (hc.reached)
    Say(options.report,
        "\nHc = %.2f +- %.2f cm (bisection: P within %.0f%% of the plateau P = %.4g N at H = "
        "%.3g cm; bracket %.2f-%.2f cm; %s)\n",
        100 * hc.hc_m, 100 * hc.hc_sd_m, 100 * search.margin, hc.plateau_N, 100 * search.high_m,
        100 * hc.bracket_low_m, 100 * hc.bracket_high_m,
        hc.seed_scatter_included ? "seed scatter included" : "one seed: bracket width only");
  // (A search that did not reach Hc has said why in the table's last line.)
  if (hc.reached && !hc.note.empty()) Say(options.report, "note: %s\n", hc.note.c_str());
  return failed;
}

}  // namespace dembuf
