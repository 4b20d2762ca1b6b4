// dembuf: the command-line client. Local mode (run, sweep, plot, scene) runs scenes in this
// process with the engine; remote mode (submit, sweep, list, status, watch, fetch, cancel,
// server-info) talks to a dembufd. `sweep` goes to a daemon when --server or DEMBUF_SERVER
// names one, unless --local is given.
//
// Exit codes: 0 success; 1 a runtime failure (files, the server); 2 bad input (a scene, a
// request, the arguments); 3 a simulation failed (unstable) or a remote job failed; 130 and
// 143 interrupted by SIGINT and SIGTERM.
#include <fcntl.h>
#include <unistd.h>
#include <CLI/CLI.hpp>
#include <atomic>
#include <csignal>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <iostream>
#include <optional>
#include <thread>

#include "compare.h"
#include "cost_check.h"
#include "dembuf/study/bed/bed.h"
#include "dembuf/study/files/bed_export.h"
#include "dembuf/study/files/run_output.h"
#include "dembuf/study/files/snapshot_report.h"
#include "dembuf/study/impact/impact.h"
#include "dembuf/study/run/resource_estimate.h"
#include "dembuf/study/scene/errors.h"
#include "dembuf/study/scene/scene_fields.h"
#include "dembuf/study/sweep/sweep_plan.h"
#include "dembuf/study/text/text_limits.h"
#include "dembuf/study/version.h"
#include "plots.h"
#include "progress.h"
#if DEMBUF_SERVICE
#include "remote.h"
#endif
#include "scene_input.h"
#include "sweep.h"

namespace fs = std::filesystem;
using namespace dembuf;

namespace {

// The exit codes (the app's footer and README.md list them).
constexpr int kExitRuntime = 1;
constexpr int kExitBadInput = 2;
constexpr int kExitUnstable = 3;

// Set by SIGINT and SIGTERM; the engine looks at it every step and stops with Cancelled.
std::atomic<bool> g_interrupted{false};
std::atomic<int> g_signal{0};

extern "C" void OnInterrupt(int signal) {
  g_signal.store(signal);
  g_interrupted.store(true);
}

void CatchInterrupts() {
  std::signal(SIGINT, OnInterrupt);
  std::signal(SIGTERM, OnInterrupt);
}

// 130 for SIGINT (Ctrl-C), 143 for SIGTERM: 128 + the signal, as a shell reports a program
// the signal ended.
int InterruptedExit() {
  const int signal = g_signal.load();
  return 128 + (signal ? signal : SIGINT);
}

const char* SignalName() {
  return g_signal.load() == SIGTERM ? "SIGTERM" : "SIGINT";
}

fs::path DefaultOutputDir(const std::string& kind) {
  std::time_t now = std::time(nullptr);
  char stamp[32];
  std::strftime(stamp, sizeof stamp, "%Y%m%d-%H%M%S", std::gmtime(&now));
  const std::string base = "dembuf-" + kind + "-" + stamp;
  fs::path dir = base;
  for (int k = 2; fs::exists(dir); ++k) dir = base + "-" + std::to_string(k);
  return dir;
}

struct RunOptions {
  std::string scene_file;
  std::string preset;
  std::string accuracy;
  std::vector<std::string> overrides;
  std::string out_dir;
  bool force = false;
  std::string bed_cache;
  bool no_bed_cache = false;
  std::vector<std::string> vary;
  std::string find_hc;  ///< "LOW:HIGH[:TOLERANCE]" in metres: dembuf sweep --find-hc
  int seeds = 1;
  int jobs = 1;
  bool local = false;
  std::string name;
  std::string samples_out;  ///< also stream the samples, packed, to this file
  bool no_plots = false;
  bool source_only = false;   ///< prepare-bed: only the source bed
  bool dry_run = false;       ///< print the estimate and stop
  bool yes = false;           ///< run even past this machine's limits
  bool json = false;          ///< print the result as JSON on stdout, the rest on stderr
  std::string command_line;   ///< this program's arguments, for the results' provenance
  std::string export_format;  ///< bed export: text, lammps or vtp
  std::string export_out;     ///< bed export: the file
};

// Where the report for people goes: stdout (the default), stderr (with --json, so that
// stdout carries the JSON alone) or nowhere (-q); the report's own prints and gnuplot's too.
class ReportDestination {
 public:
  enum class To { kStdout, kStderr, kNowhere };
  explicit ReportDestination(To to) {
    if (to == To::kStdout) return;
    std::fflush(stdout);
    const int target = to == To::kStderr ? dup(STDERR_FILENO) : open("/dev/null", O_WRONLY);
    if (target < 0) return;
    m_saved = dup(STDOUT_FILENO);
    if (m_saved >= 0) dup2(target, STDOUT_FILENO);
    close(target);
  }
  ReportDestination(const ReportDestination&) = delete;
  ReportDestination& operator=(const ReportDestination&) = delete;
  ~ReportDestination() { Restore(); }
  /// Stdout is stdout again (for the JSON).
  void Restore() {
    if (m_saved < 0) return;
    std::fflush(stdout);
    dup2(m_saved, STDOUT_FILENO);
    close(m_saved);
    m_saved = -1;
  }

 private:
  int m_saved = -1;
};

ReportDestination::To ReportTo(const RunOptions& opt) {
  if (cli::GetVerbosity() == cli::Verbosity::kQuiet) return ReportDestination::To::kNowhere;
  return opt.json ? ReportDestination::To::kStderr : ReportDestination::To::kStdout;
}

int Cores() {
  return static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
}

// Prepared beds are kept between runs: $DEMBUF_BED_CACHE, else $XDG_CACHE_HOME/dembuf/beds,
// else ~/.cache/dembuf/beds.
fs::path BedCacheDir(const RunOptions& opt) {
  if (opt.no_bed_cache) return {};
  if (!opt.bed_cache.empty()) return opt.bed_cache;
  if (const char* env = std::getenv("DEMBUF_BED_CACHE"); env && *env) return env;
  if (const char* xdg = std::getenv("XDG_CACHE_HOME"); xdg && *xdg)
    return fs::path(xdg) / "dembuf" / "beds";
  if (const char* home = std::getenv("HOME"); home && *home)
    return fs::path(home) / ".cache" / "dembuf" / "beds";
  return {};
}

void PrintWarnings(const std::vector<std::string>& warnings) {
  for (const std::string& w : warnings) std::fprintf(stderr, "dembuf: warning: %s\n", w.c_str());
}

void PrintSummary(const ImpactSummary& s, const fs::path& dir) {
  std::printf("beads %zu, dt %.4g us (alpha %.3g of %.4g us), %lld steps, wall time %.2f s\n",
              s.beads, s.dt_s * 1e6, s.dt_s / s.critical_dt_s, s.critical_dt_s * 1e6,
              static_cast<long long>(s.steps), s.wall_time_s);
  std::printf("damping A = %.4g s (e = %.4f at %.3g m/s)\n", s.damping.damping_A_s,
              s.damping.restitution_at_ref, s.damping.ref_speed_m_s);
  if (s.first_contact_time_s >= 0.0)
    std::printf("first contact at %.4f ms, impact speed %.4g m/s\n", s.first_contact_time_s * 1e3,
                s.impact_speed_m_s);
  std::printf("peak plate force %.6g N at t = %.4f ms\n", s.peak_plate_force_N,
              s.peak_plate_force_time_s * 1e3);
  if (s.beads > 0) {
    std::printf("bed H = %.2f cm, C0 = %.3f, %zu beads\n", s.bed.thickness_m * 100,
                s.bed.solid_fraction, s.beads);
    auto peak = [](bool has, const ForcePeak& p) {
      char buf[64];
      if (!has) return std::string("none");
      std::snprintf(buf, sizeof buf, "%.4g N at %.4f ms", p.force_N, p.time_s * 1e3);
      return std::string(buf);
    };
    std::printf("Pa %s, Pb %s\n", peak(s.peaks.has_pa, s.peaks.pa).c_str(),
                peak(s.peaks.has_pb, s.peaks.pb).c_str());
    std::printf("P = %.4g N, bare-plate Pa0 = %.4g N, lambda = %.1f%%, crater depth %.2f cm\n",
                s.peaks.p_N, s.reference_peak_N, 100 * s.lambda, 100 * s.crater_depth_m);
  }
  std::printf("ended at %.4f ms: %s\n", s.end_time_s * 1e3, s.end_reason.c_str());
  if (s.max_overlap_ratio > 0.1)
    std::printf(
        "note: the largest contact overlap reached %.0f%% of a bead radius, beyond the "
        "small strains Hertz theory assumes\n",
        100 * s.max_overlap_ratio);
  std::printf("wrote %s and %s\n", (dir / "plate_force.csv").c_str(),
              (dir / "summary.json").c_str());
}

int RunLocal(const RunOptions& opt) {
  ReportDestination report(ReportTo(opt));
  // Everything about the scene, its cost and its folder is checked before anything is
  // prepared or written.
  Scene scene = cli::ResolveScene(opt.scene_file, opt.preset, opt.overrides, opt.accuracy);
  PrintWarnings(SceneWarnings(scene));
  if (cli::GetVerbosity() == cli::Verbosity::kVerbose) {
    std::cerr << "# the resolved scene\n";
    PrintScene(scene, std::cerr);
  }
  BedCache beds(BedCacheDir(opt));
  const ResourceEstimate cost = EstimateResources(scene);
  if (opt.dry_run) {
    std::printf("%s", cli::DescribeRun(cost, beds, Cores()).c_str());
    return 0;
  }
  const fs::path dir = opt.out_dir.empty() ? DefaultOutputDir("run") : fs::path(opt.out_dir);
  if (fs::exists(dir / "summary.json") && !opt.force) {
    std::fprintf(stderr,
                 "dembuf: error: %s already holds a run (summary.json); choose another --out "
                 "or pass --force to replace it\n",
                 dir.c_str());
    return kExitRuntime;
  }
  if (std::error_code same; !opt.scene_file.empty() && fs::exists(dir / "scene.toml") &&
                            fs::equivalent(opt.scene_file, dir / "scene.toml", same)) {
    std::fprintf(stderr,
                 "dembuf: error: the scene file %s is where the run writes its resolved scene; "
                 "copy it elsewhere or choose another --out\n",
                 opt.scene_file.c_str());
    return kExitRuntime;
  }
  cli::CheckLocalCost({scene}, {cost}, dir, 1, beds, opt.yes);
  // The run before (replaced, or one that failed or was interrupted) goes first: whatever
  // happens to this one, nothing of that one is left to be taken for its result.
  if (opt.force || fs::exists(dir / "failure.json") || fs::exists(dir / "incomplete.json"))
    report::RemoveRunOutputs(dir);
  const bool new_folder = !fs::exists(dir);
  fs::create_directories(dir);
  // The resolved scene beside the results: what ran, in a file that runs it again.
  report::WriteFileAtomically(dir / "scene.toml", report::SceneText(scene));
  report::RunContext context = report::RunStartingNow(opt.command_line);
  CatchInterrupts();

  std::string phase = "bed preparation";
  cli::ProgressLine progress(stderr);
  std::optional<report::SampleCsvWriter> csv;
  std::optional<report::SampleStreamWriter> stream;
  auto partial = [&] { return csv ? csv->partial_path().string() : std::string("none"); };
  try {
    BedRequest bed_request;
    bed_request.cancel = &g_interrupted;
    cli::BedProgressLine bed_progress(stderr);
    bed_request.on_progress = [&](const BedProgress& p) { bed_progress.Update(p); };
    World world = BuildWorld(scene, &beds, &bed_request);
    for (const auto& [stage, count] : beds.prepared_counts())
      std::fprintf(stderr, "%sprepared %d %s bed(s)\n", bed_progress.open() ? "\n" : "", count,
                   stage.c_str());
    if (!world.bed.note.empty()) std::fprintf(stderr, "imported bed: %s\n", world.bed.note.c_str());

    phase = "impact";
    csv.emplace(dir / "plate_force.csv");
    if (!opt.samples_out.empty()) stream.emplace(opt.samples_out);
    RunControl control;
    control.on_sample = [&](const ImpactSample& s) {
      csv->Write(s);
      if (stream) stream->Write(s);
    };
    // The same impact on the bare plate (run for lambda), drawn beside this one.
    std::vector<ImpactSample> bare;
    control.on_reference_sample = [&](const ImpactSample& s) { bare.push_back(s); };
    control.on_progress = [&](const ImpactProgress& p) { progress.Update(p); };
    control.cancel = &g_interrupted;
    report::ParaViewFiles paraview(scene.cylinder.radius_m, scene.beads.diameter_max_m);
    control.on_snapshot = [&](const ImpactSnapshot& snap) {
      report::WriteResultFiles(paraview.AddSnapshot(snap), dir);
    };
    control.on_frame = [&](const ImpactSnapshot& frame) {
      report::WriteResultFiles(paraview.AddFrame(frame), dir);
    };
    ImpactSummary summary = RunImpact(std::move(world), scene, control);
    progress.Finish();
    csv->Commit();
    if (!bare.empty())
      report::WriteFileAtomically(dir / "plate_force_bare.csv", report::SamplesToCsv(bare));
    if (stream) stream->Close();
    context.finished_at = report::UtcNow();
    const nlohmann::json summary_json = report::SummaryToJson(summary, scene, context);
    report::WriteFileAtomically(dir / "summary.json", summary_json.dump(2) + "\n");
    PrintSummary(summary, dir);
    phase = "plots";
    if (!opt.no_plots) cli::PlotIfPossible(dir);
    if (g_interrupted) throw Cancelled();  // during the plots: the results are complete
    if (opt.json) {
      report.Restore();
      std::printf("%s\n",
                  nlohmann::json{{"out_dir", fs::absolute(dir).string()}, {"summary", summary_json}}
                      .dump(2)
                      .c_str());
    }
    return 0;
  } catch (const dem::SimulationError& e) {
    progress.Finish();
    nlohmann::json failure = {{"error", e.what()},
                              {"phase", phase},
                              {"step", e.step()},
                              {"time_s", e.time_s()},
                              {"scene", report::SceneToJson(scene)}};
    report::WriteFileAtomically(dir / "failure.json", failure.dump(2) + "\n");
    std::fprintf(stderr, "dembuf: run failed in the %s: %s\n  samples up to the failure: %s\n",
                 phase.c_str(), e.what(), partial().c_str());
    return kExitUnstable;
  } catch (const Cancelled&) {
    progress.Finish();
    const bool complete = phase == "plots";  // the results were written before the plots
    const nlohmann::json incomplete = {{"interrupted_by", SignalName()},
                                       {"phase", phase},
                                       {"complete", complete},
                                       {"samples_so_far", complete ? "" : partial()}};
    report::WriteFileAtomically(dir / "incomplete.json", incomplete.dump(2) + "\n");
    if (complete)
      std::fprintf(stderr, "dembuf: interrupted by %s while plotting; the results are complete\n",
                   SignalName());
    else
      std::fprintf(stderr, "dembuf: interrupted by %s in the %s; %s; samples so far: %s\n",
                   SignalName(), phase.c_str(),
                   phase == "bed preparation" ? "the bed stages done are cached"
                                              : "marked in incomplete.json",
                   partial().c_str());
    return InterruptedExit();
  } catch (...) {
    // Anything else (the disk, say) is reported by main; a folder made for nothing goes.
    std::error_code error;
    if (new_folder && fs::is_empty(dir, error)) fs::remove(dir, error);
    throw;
  }
}

// Prepares a scene's bed (or only its source bed) into the bed cache, and nothing else: a
// cluster runs this as a job of its own that the impacts cutting the bed wait for.
// prepare-bed, and bed export (which writes the bed too).
int PrepareBedCommand(const RunOptions& opt) {
  const Scene scene = cli::ResolveScene(opt.scene_file, opt.preset, opt.overrides, opt.accuracy);
  if (!opt.export_out.empty() && fs::exists(opt.export_out) && !opt.force) {
    std::fprintf(stderr, "dembuf: error: %s exists; choose another --out or pass --force\n",
                 opt.export_out.c_str());
    return kExitRuntime;
  }
  const fs::path dir = BedCacheDir(opt);
  if (dir.empty())
    throw SceneError("--bed-cache", "prepare-bed keeps the bed in a bed cache: give a folder");
  BedCache beds(dir);
  CatchInterrupts();
  BedRequest request;
  request.cancel = &g_interrupted;
  cli::BedProgressLine progress(stderr);
  request.on_progress = [&](const BedProgress& p) { progress.Update(p); };
  try {
    const PreparedBed bed =
        opt.source_only ? GetSourceBed(scene, beds, request) : GetBed(scene, beds, request);
    if (progress.open()) std::fprintf(stderr, "\n");
    std::printf("%s bed %s: %zu beads, H = %.5f m, C0 = %.4f, in %s\n", bed.stage.c_str(),
                bed.hash.c_str(), bed.beads.size(), bed.surface_m, bed.solid_fraction, dir.c_str());
    if (!opt.export_out.empty()) {
      char title[160];
      std::snprintf(title, sizeof title, "dembuf %s bed %s, %zu beads, H = %.5f m",
                    bed.stage.c_str(), bed.hash.c_str(), bed.beads.size(), bed.surface_m);
      report::WriteFileAtomically(
          opt.export_out, ExportBed(bed.beads, scene, *ParseBedFormat(opt.export_format), title));
      std::printf("wrote %s (%s)\n", opt.export_out.c_str(), opt.export_format.c_str());
    }
    return 0;
  } catch (const dem::SimulationError& e) {
    std::fprintf(stderr, "dembuf: bed preparation failed: %s\n", e.what());
    return kExitUnstable;
  } catch (const Cancelled&) {
    std::fprintf(stderr, "dembuf: bed preparation interrupted by %s\n", SignalName());
    return InterruptedExit();
  }
}

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

int SweepCommand(const RunOptions& opt) {
  ReportDestination report(ReportTo(opt));
  const Scene base = cli::ResolveScene(opt.scene_file, opt.preset, opt.overrides, opt.accuracy);
  cli::SweepOptions sweep;
  std::optional<HcSearchOptions> hc_search;
  if (!opt.find_hc.empty()) {
    if (!opt.vary.empty())
      throw SceneError("--find-hc", "it varies bed.thickness_m itself; leave out --vary");
    hc_search = ParseHcRange(opt.find_hc);
  }
  for (const auto& spec : opt.vary) sweep.axes.push_back(ParseSweepAxis(spec));
  if (opt.seeds < 1 || opt.seeds > 1000)
    throw SceneError("--seeds", std::to_string(opt.seeds) + " is out of range: 1 to 1000");
  if (opt.jobs < 1 || opt.jobs > 256)
    throw SceneError("--jobs", std::to_string(opt.jobs) + " is out of range: 1 to 256");
  sweep.seeds = opt.seeds;
  sweep.jobs = opt.jobs;
  sweep.command_line = opt.command_line;
  sweep.out_dir = opt.out_dir.empty() ? DefaultOutputDir("sweep") : fs::path(opt.out_dir);
  BedCache beds(BedCacheDir(opt));
  std::vector<Scene> scenes;
  std::vector<ResourceEstimate> costs;
  std::vector<std::string> warnings;
  // The search's cost: its deepest bed for every seed, at each of the runs it may make (the
  // two ends and each halving of the range down to the tolerance).
  std::vector<SweepAxis> planned = sweep.axes;
  int repeats = 1;
  if (hc_search) {
    planned = {MakeSweepAxis("bed.thickness_m", {std::to_string(hc_search->high_m)}, "")};
    const int halvings = static_cast<int>(
        std::ceil(std::log2((hc_search->high_m - hc_search->low_m) / hc_search->tolerance_m)));
    repeats = 2 + std::min(halvings, hc_search->max_steps);
  }
  for (const SweepRun& run : ExpandSweep(base, WithSeedAxis(planned, opt.seeds, base.bed.seed))) {
    for (int k = 0; k < repeats; ++k) {
      scenes.push_back(run.scene);
      costs.push_back(EstimateResources(run.scene));
    }
    for (const std::string& w : SceneWarnings(run.scene))
      if (std::find(warnings.begin(), warnings.end(), w) == warnings.end()) warnings.push_back(w);
  }
  PrintWarnings(warnings);
  if (opt.dry_run) {
    std::printf("%s", cli::DescribeSweep(costs, beds, opt.jobs, Cores()).c_str());
    return 0;
  }
  cli::CheckLocalCost(scenes, costs, sweep.out_dir, opt.jobs, beds, opt.yes);
  // An existing folder is resumed: runs whose summary.json matches their scene are kept.
  CatchInterrupts();
  sweep.cancel = &g_interrupted;
  int failed = 0;
  try {
    failed = hc_search ? cli::RunHcSearch(base, sweep, *hc_search, beds)
                       : cli::RunSweep(base, sweep, beds);
  } catch (const Cancelled&) {
    // The search stops between its steps: reported below as any interrupted sweep.
  }
  if (g_interrupted) {
    const nlohmann::json incomplete = {{"interrupted_by", SignalName()}, {"complete", false}};
    report::WriteFileAtomically(sweep.out_dir / "incomplete.json", incomplete.dump(2) + "\n");
    std::fprintf(stderr,
                 "dembuf: sweep interrupted by %s; the runs done are kept and resume when the "
                 "same sweep is given this folder again\n",
                 SignalName());
    return InterruptedExit();
  }
  std::filesystem::remove(sweep.out_dir / "incomplete.json");
  cli::PlotIfPossible(sweep.out_dir);
  if (opt.json) {
    report.Restore();
    std::ifstream summary_file(sweep.out_dir / "summary.json");
    const nlohmann::json summary = nlohmann::json::parse(summary_file, nullptr, false);
    std::printf("%s\n", nlohmann::json{{"out_dir", fs::absolute(sweep.out_dir).string()},
                                       {"failed", failed},
                                       {"summary", summary}}
                            .dump(2)
                            .c_str());
  }
  return failed == 0 ? 0 : kExitUnstable;
}

int PrintSceneCommand(const RunOptions& opt) {
  Scene scene = cli::ResolveScene(opt.scene_file, opt.preset, opt.overrides, opt.accuracy);
  PrintWarnings(SceneWarnings(scene));
  PrintScene(scene, std::cout);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"dembuf: DEM simulation of impacts on granular buffer layers"};
  app.set_version_flag("--version", std::string("dembuf ") + kVersion);
  app.require_subcommand(1);
  // Options of the program work after the command too: dembuf run -q, dembuf list --server A.
  app.fallthrough();
  bool quiet = false, verbose = false;
  CLI::Option* quiet_flag = app.add_flag(
      "-q,--quiet", quiet, "no progress and no report: errors, warnings and results only");
  app.add_flag("-v,--verbose", verbose,
               "also the resolved scene before a run, and progress every second in a log")
      ->excludes(quiet_flag);

  RunOptions opt;
  // A token given on the command line is not kept with the jobs and results it asks for.
  opt.command_line = report::ShellCommandLine(argc, argv, {"--token"});
  auto add_scene_args = [&](CLI::App* cmd) {
    cmd->add_option("scene", opt.scene_file,
                    "scene file (TOML); default: the paper's Table 1 scene");
    cmd->add_option("--preset", opt.preset, "start from a paper experiment: e1, e2, e3, e4, e5");
    cmd->add_option("--accuracy", opt.accuracy,
                    "draft, standard or reference: time step and settling tolerance together "
                    "(docs/accuracy-cost.md)");
    cmd->add_option("--set", opt.overrides,
                    "override a scene field: dotted.name=value (repeatable)")
        ->allow_extra_args(false);
  };

  CLI::App* run = app.add_subcommand("run", "run a scene locally, in this process");
  add_scene_args(run);
  run->add_option("--out", opt.out_dir, "output folder (default: dembuf-run-<UTC time>)");
  run->add_flag("--force", opt.force, "replace a run already in the output folder");
  run->add_option("--bed-cache", opt.bed_cache,
                  "folder of prepared beds (default ~/.cache/dembuf/beds)");
  run->add_flag("--no-bed-cache", opt.no_bed_cache, "keep prepared beds in memory only");
  run->add_flag("--dry-run", opt.dry_run,
                "print what the run would cost (beads, steps, output, memory, predicted time, "
                "cached beds) and stop");
  run->add_flag("--yes", opt.yes, "run even when the estimate passes this machine's limits");
  run->add_flag("--no-plots", opt.no_plots, "do not draw plots");
  run->add_flag("--json", opt.json,
                "print the output folder and summary.json as JSON on stdout, the report on "
                "stderr");
  run->add_option("--samples-out", opt.samples_out,
                  "also stream the samples to this file as they come, as rows of six "
                  "little-endian doubles (for a daemon following a cluster job)");

  CLI::App* prepare_bed = app.add_subcommand(
      "prepare-bed", "prepare a scene's bed into the bed cache, without the impact");
  add_scene_args(prepare_bed);
  prepare_bed->add_option("--bed-cache", opt.bed_cache,
                          "folder of prepared beds (default ~/.cache/dembuf/beds)");
  prepare_bed->add_flag("--source-only", opt.source_only,
                        "only the settled source bed that the bed is cut from");

  CLI::App* bed = app.add_subcommand("bed", "beds for other programs");
  bed->require_subcommand(1);
  CLI::App* bed_export = bed->add_subcommand(
      "export",
      "write a scene's bed (from the bed cache, prepared first if need be) for ParaView, "
      "LAMMPS or Yade, or to import again");
  add_scene_args(bed_export);
  bed_export->add_option("--bed-cache", opt.bed_cache,
                         "folder of prepared beds (default ~/.cache/dembuf/beds)");
  bed_export->add_flag("--source-only", opt.source_only,
                       "the settled source bed that the bed is cut from");
  bed_export
      ->add_option("--format", opt.export_format,
                   "text (x y z radius, as bed.import reads), lammps (a data file for "
                   "read_data, atom_style sphere) or vtp (VTK XML, for ParaView)")
      ->check(CLI::IsMember({"text", "lammps", "vtp"}))
      ->required();
  bed_export->add_option("--out", opt.export_out, "the file to write")->required();
  bed_export->add_flag("--force", opt.force, "replace the file if it exists");

  CLI::App* sweep = app.add_subcommand("sweep", "run a scene over ranges of fields and seeds");
  add_scene_args(sweep);
  sweep
      ->add_option("--vary", opt.vary,
                   "dotted.field=START:STOP:STEP or dotted.field=v1,v2,... (repeatable)")
      ->allow_extra_args(false);
  sweep->add_option("--find-hc", opt.find_hc,
                    "LOW:HIGH[:TOL] (m): find Hc by bisection of bed.thickness_m in that range "
                    "(P within 10% of its value at HIGH), to TOL (default 0.001)");
  sweep->add_option("--seeds", opt.seeds,
                    "N bed seeds for every point, from bed.seed on (default 1)");
  sweep->add_option("--jobs", opt.jobs,
                    "runs at once (default 1); the cores are shared among the runs going, so a run "
                    "that the others wait for gets them all");
  sweep->add_option("--out", opt.out_dir, "output folder (default: dembuf-sweep-<UTC time>)");
  sweep->add_option("--bed-cache", opt.bed_cache, "folder of prepared beds");
  sweep->add_flag("--no-bed-cache", opt.no_bed_cache, "keep prepared beds in memory only");
  sweep->add_flag("--dry-run", opt.dry_run, "print what the sweep would cost and stop");
  sweep->add_flag("--yes", opt.yes, "run even when the estimate passes this machine's limits");

  sweep->add_flag("--local", opt.local, "run here even when a server is configured");
  sweep->add_flag("--json", opt.json,
                  "print the result as JSON on stdout (locally: the folder, the failed runs and "
                  "summary.json; on a server: the sweep and its job ids), the report on stderr");
  sweep->add_option("--name", opt.name, "a name for the sweep (remote)");

#if DEMBUF_SERVICE
  // Remote mode.
  std::string server_flag;
  cli::Remote remote;
  app.add_option("--server", server_flag,
                 "dembufd address host:port (default: $DEMBUF_SERVER, else 127.0.0.1:50051)");
  app.add_option("--owner", remote.owner, "owner of submitted jobs (default: $USER)");
  app.add_option("--token", remote.token,
                 "API token of a server that needs one (default: $DEMBUF_TOKEN)");
  app.add_option("--tls-ca", remote.tls_ca,
                 "speak TLS, trusting this PEM certificate (default: $DEMBUF_TLS_CA)");

  CLI::App* submit = app.add_subcommand("submit", "queue a scene on the server; prints the job id");
  add_scene_args(submit);
  submit->add_option("--name", opt.name, "a name for the job");

  cli::ListOptions list_options;
  CLI::App* list = app.add_subcommand("list", "list the server's jobs (or sweeps), newest first");
  list->add_option("--state", list_options.state,
                   "only jobs in this state: queued, preparing_bed, running, done, failed, "
                   "cancelled");
  list->add_option("--owner", list_options.owner, "only this owner's");
  list->add_option("--sweep", list_options.sweep, "only this sweep's jobs");
  list->add_option("--limit", list_options.limit, "at most this many (default 20)");
  list->add_flag("--sweeps", list_options.sweeps, "list sweeps instead of jobs");
  list->add_flag("--json", list_options.json, "print JSON (docs/service.md) instead of a table");

  std::int64_t id = 0;
  bool is_sweep = false;
  CLI::App* status = app.add_subcommand("status", "a job's state, progress and results");
  status->add_option("id", id, "job id (or sweep id with --sweep)")->required();
  status->add_flag("--sweep", is_sweep, "the id is a sweep's");
  bool json = false;
  status->add_flag("--json", json, "print JSON (docs/service.md) instead of text");

  bool watch_csv = false;
  std::int64_t watch_from = 0;
  CLI::App* watch = app.add_subcommand("watch", "follow a job's plate force live");
  watch->add_option("id", id, "job id")->required();
  watch->add_flag("--csv", watch_csv, "print every sample as a CSV row");
  watch->add_option("--from", watch_from, "first sample index (to resume)");

  std::string fetch_dir;
  bool no_plots = false;
  CLI::App* fetch = app.add_subcommand(
      "fetch", "write a finished job's files (summary.json, plate_force.csv, ...) or a sweep's");
  fetch->add_option("id", id, "job id (or sweep id with --sweep)")->required();
  fetch->add_flag("--sweep", is_sweep, "the id is a sweep's");
  fetch->add_option("--out", fetch_dir, "output folder")->required();
  fetch->add_flag("--no-plots", no_plots, "do not draw plots");
  bool fetch_force = false;
  fetch->add_flag("--force", fetch_force, "replace what an earlier fetch wrote into the folder");

  CLI::App* cancel = app.add_subcommand("cancel", "cancel a queued or running job (or sweep)");
  cancel->add_option("id", id, "job id (or sweep id with --sweep)")->required();
  cancel->add_flag("--sweep", is_sweep, "cancel every unfinished job of the sweep");

  CLI::App* info = app.add_subcommand("server-info", "the server's version, workers and queue");
  info->add_flag("--json", json, "print JSON (docs/service.md) instead of text");
#endif

  CLI::App* plot = app.add_subcommand("plot", "draw PNG plots of a run or sweep folder (gnuplot)");
  std::string plot_dir;
  plot->add_option("folder", plot_dir, "a run or sweep output folder")->required();

  CLI::App* compare = app.add_subcommand(
      "compare", "put runs or sweeps beside the paper's numbers and the Hertz bare-plate peak");
  std::vector<std::string> compare_dirs;
  std::string compare_out;
  bool compare_no_plots = false;
  compare->add_option("folders", compare_dirs, "run or sweep output folders")->required();
  compare->add_option("--out", compare_out, "where compare.csv goes (default: the first folder)");
  compare->add_flag("--no-plots", compare_no_plots, "do not draw compare.png");

  CLI::App* scene_cmd = app.add_subcommand("scene", "show a scene with every default and unit");
  add_scene_args(scene_cmd);
  bool print_flag = false;
  scene_cmd->add_flag("--print", print_flag, "print the complete scene as TOML (the default)");

#if !DEMBUF_SERVICE
  // Without the service the remote commands do not exist: say why instead of CLI11's
  // "a subcommand is required".
  for (const char* remote :
       {"submit", "list", "status", "watch", "fetch", "cancel", "server-info"}) {
    if (argc > 1 && std::string(argv[1]) == remote) {
      std::fprintf(stderr,
                   "dembuf: %s talks to a dembufd, and this dembuf was built without the service "
                   "(cmake -DDEMBUF_SERVICE=OFF); run and sweep work here\n",
                   remote);
      return kExitBadInput;
    }
  }
#endif
  app.footer(
      "Exit codes: 0 done; 1 a runtime failure (files, the server); 2 bad input (a scene, a "
      "request, the arguments); 3 a run became unstable or a remote job failed; 130 and 143 "
      "interrupted by SIGINT (Ctrl-C) and SIGTERM.");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help and --version end well; any other mistake in the arguments is bad input.
    return app.exit(e) == 0 ? 0 : kExitBadInput;
  }

#if DEMBUF_SERVICE
  remote.address = cli::ServerAddress(server_flag);
  remote.command_line = opt.command_line;
  auto from_env = [](std::string& value, const char* name) {
    if (const char* env = std::getenv(name); value.empty() && env && *env) value = env;
  };
  from_env(remote.token, "DEMBUF_TOKEN");
  from_env(remote.tls_ca, "DEMBUF_TLS_CA");
  // A token says who the user is; without one (a trusted loopback daemon) the owner is
  // --owner, else $USER. An admin's token with --owner files the job under that owner.
  if (remote.owner.empty() && remote.token.empty()) {
    const char* user = std::getenv("USER");
    remote.owner = user && *user ? user : "anonymous";
  }
  const cli::RemoteScene remote_scene{opt.scene_file, opt.preset, opt.accuracy, opt.overrides};
#endif
  // A name is shown in tables and on terminals (and protobuf sends only UTF-8).
  if (const std::string problem = DisplayTextProblem(opt.name); !problem.empty()) {
    std::fprintf(stderr, "dembuf: --name: %s\n", problem.c_str());
    return kExitBadInput;
  }
  cli::SetVerbosity(quiet     ? cli::Verbosity::kQuiet
                    : verbose ? cli::Verbosity::kVerbose
                              : cli::Verbosity::kNormal);
  try {
    if (run->parsed()) return RunLocal(opt);
    if (prepare_bed->parsed() || bed_export->parsed()) return PrepareBedCommand(opt);
    if (sweep->parsed()) {
#if DEMBUF_SERVICE
      if (!opt.local && cli::ServerGiven(server_flag))
        return cli::RemoteSweep(remote, remote_scene, opt.vary, opt.seeds, opt.name, opt.json);
#endif
      return SweepCommand(opt);
    }
#if DEMBUF_SERVICE
    if (submit->parsed()) return cli::RemoteSubmit(remote, remote_scene, opt.name);
    if (list->parsed()) return cli::RemoteList(remote, list_options);
    if (status->parsed()) return cli::RemoteStatus(remote, id, is_sweep, json);
    if (watch->parsed()) return cli::RemoteWatch(remote, id, watch_csv, watch_from);
    if (fetch->parsed())
      return cli::RemoteFetch(remote, id, is_sweep, fetch_dir, !no_plots, fetch_force);
    if (cancel->parsed()) return cli::RemoteCancel(remote, id, is_sweep);
    if (info->parsed()) return cli::RemoteServerInfo(remote, json);
#endif
    if (plot->parsed()) {
      for (const auto& file : cli::PlotFolder(plot_dir)) std::printf("%s\n", file.c_str());
      return 0;
    }
    if (scene_cmd->parsed()) return PrintSceneCommand(opt);
    if (compare->parsed())
      return cli::CompareCommand({compare_dirs.begin(), compare_dirs.end()}, compare_out,
                                 !compare_no_plots);
  } catch (const SceneError& e) {
    std::fprintf(stderr, "dembuf: invalid scene: %s\n", e.what());
    return kExitBadInput;
  } catch (const ResourceError& e) {
    std::fprintf(stderr, "dembuf: too costly: %s\n", e.what());
    return kExitBadInput;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "dembuf: error: %s\n", e.what());
    return kExitRuntime;
  }
  return kExitRuntime;
}
