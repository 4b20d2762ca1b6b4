// dembuf sweep, here: checks the sweep's every scene and its cost, runs it (sweep.h) or the Hc
// search, and reports an interruption.
#include <cmath>
#include <cstdio>
#include <fstream>
#include <optional>

#include "dembuf/core/threads.h"
#include "dembuf/study/files/own_files.h"
#include "dembuf/study/files/run_output.h"
#include "dembuf/study/run/resource_estimate.h"
#include "dembuf/study/scene/errors.h"
#include "dembuf/study/scene/scene_fields.h"
#include "dembuf/study/sweep/local_sweep.h"
#include "dembuf/study/sweep/sweep_plan.h"
#include "dembuf/study/sweep/sweep_report.h"
#include "local/commands.h"
#include "local/cost_check.h"
#include "local/plots.h"
#include "local/scene_input.h"
#include "terminal/exit_codes.h"
#include "terminal/interrupts.h"
#include "terminal/progress.h"

namespace dembuf::cli {

namespace fs = std::filesystem;

namespace {

// --find-hc LOW:HIGH[:TOL], in metres.
HcSearchOptions ParseHcRange(const std::string& text) {
  HcSearchOptions o;
  std::vector<double> v;
  std::size_t start = 0;
  while (start <= text.size() && v.size() < 4) {
    const std::size_t end = std::min(text.find(':', start), text.size());
    const std::string part = text.substr(start, end - start);
    char* rest = nullptr;
    const double x = std::strtod(part.c_str(), &rest);
    if (part.empty() || *rest != '\0' || !std::isfinite(x))
      throw SceneError("--find-hc",
                       "\"" + part.substr(0, 40) + "\" is not a number (LOW:HIGH[:TOL] in m)");
    v.push_back(x);
    start = end + 1;
  }
  if (v.size() < 2 || v.size() > 3)
    throw SceneError("--find-hc", "\"" + text.substr(0, 60) + "\" is not LOW:HIGH[:TOL] (m)");
  o.low_m = v[0];
  o.high_m = v[1];
  if (v.size() == 3) o.tolerance_m = v[2];
  if (!(o.low_m > 0.0 && o.low_m < o.high_m && o.high_m <= 0.5))
    throw SceneError("--find-hc", "the range must satisfy 0 < LOW < HIGH <= 0.5 (m)");
  if (!(o.tolerance_m >= 1e-4 && o.tolerance_m < o.high_m - o.low_m))
    throw SceneError("--find-hc", "TOL must be at least 0.0001 m and below HIGH - LOW");
  return o;
}

// --seeds, --jobs and --plan-cpus within their ranges.
void CheckSweepCounts(const CommandOptions& opt) {
  if (const std::string problem = SweepSeedsProblem(opt.seeds); !problem.empty())
    throw SceneError("--seeds", problem);
  if (opt.jobs < 0 || opt.jobs > 256)
    throw SceneError("--jobs", std::to_string(opt.jobs) +
                                   " is out of range: 1 to 256, or 0 for one per usable CPU");
  if (opt.plan_cpus != 0 && (!opt.dry_run || opt.plan_cpus < 1 || opt.plan_cpus > 1024))
    throw SceneError("--plan-cpus", std::to_string(opt.plan_cpus) +
                                        (opt.dry_run ? " is out of range: 1 to 1024"
                                                     : ": it plans a dry run; add --dry-run"));
}

// The sweep's axes: the columns of --table first (read row by row), then each --vary.
std::vector<SweepAxis> SweepAxesOf(const CommandOptions& opt, std::size_t* table_columns) {
  std::vector<SweepAxis> axes;
  if (!opt.table.empty()) axes = TableAxes(ReadSweepTableFile(opt.table));
  *table_columns = axes.size();
  for (const auto& spec : opt.vary) axes.push_back(ParseSweepAxis(spec));
  return axes;
}

}  // namespace

int SweepCommand(const CommandOptions& opt) {
  const report::ClosedToOthersWriting closed;  // all it writes, plots too (own_files.h)
  ReportDestination report(opt);
  RequireJoinedAssignments("--vary", opt.vary, opt.scene_file);
  const Scene base = ResolveScene(opt.scene_file, opt.preset, opt.overrides, opt.accuracy);
  SweepOptions sweep;
  std::optional<HcSearchOptions> hc_search;
  if (!opt.find_hc.empty()) {
    if (!opt.vary.empty() || !opt.table.empty())
      throw SceneError("--find-hc",
                       "it varies bed.thickness_m itself; leave out --vary and --table");
    hc_search = ParseHcRange(opt.find_hc);
  }
  sweep.axes = SweepAxesOf(opt, &sweep.table_columns);
  CheckSweepCounts(opt);
  sweep.seeds = opt.seeds;
  sweep.long_table = opt.long_table;
  sweep.jobs = opt.jobs > 0 ? opt.jobs : std::min(256, dem::UsableCpus());
  sweep.command_line = opt.command_line;
  sweep.status = GetVerbosity() == Verbosity::kQuiet ? nullptr : stderr;
  sweep.status_interval_s = PlainProgressInterval();
  sweep.out_dir = opt.out_dir.empty() ? DefaultOutputDir("sweep") : fs::path(opt.out_dir);
  BedCache beds(BedCacheDir(opt));
  std::vector<Scene> scenes;
  std::vector<ResourceEstimate> costs;
  std::vector<std::string> warnings;
  // The search's cost: its deepest bed for every seed, at each of the runs it may make (the
  // two ends and each halving of the range down to the tolerance).
  std::vector<SweepAxis> planned = sweep.axes;
  std::size_t planned_table = sweep.table_columns;
  int repeats = 1;
  if (hc_search) {
    planned = {MakeSweepAxis("bed.thickness_m", {std::to_string(hc_search->high_m)}, "")};
    planned_table = 0;
    const int halvings = static_cast<int>(
        std::ceil(std::log2((hc_search->high_m - hc_search->low_m) / hc_search->tolerance_m)));
    repeats = 2 + std::min(halvings, hc_search->max_steps);
  }
  const std::vector<SweepRun> planned_runs =
      ExpandSweep(base, WithSeedAxis(planned, opt.seeds, base.bed.seed), 100000, {}, planned_table);
  for (const SweepRun& run : planned_runs) {
    for (int k = 0; k < repeats; ++k) {
      scenes.push_back(run.scene);
      costs.push_back(EstimateResources(run.scene));
    }
    for (const std::string& w : SceneWarnings(run.scene))
      if (std::find(warnings.begin(), warnings.end(), w) == warnings.end()) warnings.push_back(w);
  }
  PrintWarnings(warnings);
  if (opt.dry_run) {
    const int cpus = opt.plan_cpus > 0 ? opt.plan_cpus : dem::UsableCpus();
    const int jobs = opt.jobs > 0 ? opt.jobs : std::min(256, cpus);
    std::printf("%s", DescribeSweep(costs, beds, jobs, cpus).c_str());
    std::printf("%s", DescribeSweepPlan(planned_runs, beds, jobs, cpus, repeats).c_str());
    return 0;
  }
  CheckLocalCost(scenes, costs, sweep.out_dir, sweep.jobs, beds, opt.yes);
  // A folder holds one sweep: the same one is resumed (runs whose summary.json matches their
  // scene are kept), another refused unless --force.
  std::vector<std::string> varied;
  for (const SweepAxis& axis : hc_search ? planned : sweep.axes) varied.push_back(axis.field);
  if (const std::optional<std::string> refusal =
          ClaimSweepFolder(sweep.out_dir, SweepFolderKey(base, varied), opt.force)) {
    std::fprintf(stderr, "dembuf: error: %s\n", refusal->c_str());
    return kExitBadInput;
  }
  CatchInterrupts();
  sweep.cancel = &Interrupted();
  int failed = 0;
  try {
    failed = hc_search ? RunHcSearch(base, sweep, *hc_search, beds) : RunSweep(base, sweep, beds);
  } catch (const Cancelled&) {
    // The search stops between its steps: reported below as any interrupted sweep.
  }
  if (Interrupted()) {
    const nlohmann::json incomplete = {{"interrupted_by", InterruptName()}, {"complete", false}};
    report::WriteFileAtomically(sweep.out_dir / sweep_files::kIncomplete,
                                incomplete.dump(2) + "\n");
    std::fprintf(stderr,
                 "dembuf: sweep interrupted by %s; the runs done are kept and resume when the "
                 "same sweep is given this folder again\n",
                 InterruptName());
    return InterruptedExit();
  }
  std::filesystem::remove(sweep.out_dir / sweep_files::kIncomplete);
  PlotIfPossible(sweep.out_dir);
  if (opt.json) {
    report.Restore();
    std::ifstream summary_file(sweep.out_dir / sweep_files::kSummary);
    const nlohmann::json summary = nlohmann::json::parse(summary_file, nullptr, false);
    std::printf("%s\n", nlohmann::json{{"out_dir", fs::absolute(sweep.out_dir).string()},
                                       {"failed", failed},
                                       {"summary", summary}}
                            .dump(2)
                            .c_str());
  }
  return failed == 0 ? kExitDone : kExitFailed;
}

}  // namespace dembuf::cli
