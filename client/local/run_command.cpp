// dembuf run: one scene in this process, into a run folder (run/folder_recorder.h), with
// progress on stderr, the report on stdout and a failure or interruption written beside the
// results.
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <optional>

#include "dembuf/core/threads.h"
#include "dembuf/study/files/provenance.h"
#include "dembuf/study/files/run_output.h"
#include "dembuf/study/run/folder_recorder.h"
#include "dembuf/study/run/resource_estimate.h"
#include "dembuf/study/scene/errors.h"
#include "dembuf/study/scene/scene_fields.h"
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

void PrintSummary(const ImpactSummary& s, const fs::path& dir) {
  std::printf("beads %zu, dt %.4g us (alpha %.3g of %.4g us), %lld steps, wall time %.2f s\n",
              s.beads, s.dt_s * 1e6, s.dt_s / s.critical_dt_s, s.critical_dt_s * 1e6,
              static_cast<long long>(s.steps), s.wall_time_s);
  std::printf("damping A = %.4g s (e = %.4f at %.3g m/s)\n", s.contact_damping.damping_A_s,
              s.contact_damping.restitution_at_ref, s.contact_damping.ref_speed_m_s);
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
  // The scene's warnings were shown before the run; these are what the run found (they are
  // kept in summary.json and log.txt with the scene's).
  for (const std::string& w : report::ResultWarnings(s)) std::printf("note: %s\n", w.c_str());
  std::printf("wrote %s, %s and log.txt\n", (dir / report::run_files::kPlateForce).c_str(),
              (dir / report::run_files::kSummary).c_str());
}

// The run folder may take this run: not another's results (unless --force), not the scene
// file given (which the run's scene.toml would overwrite). Returns an exit code on refusal.
std::optional<int> RefuseFolder(const CommandOptions& opt, const fs::path& dir) {
  if (fs::exists(dir / report::run_files::kSummary) && !opt.force) {
    std::fprintf(stderr,
                 "dembuf: error: %s already holds a run (summary.json); choose another --out "
                 "or pass --force to replace it\n",
                 dir.c_str());
    return kExitRuntime;
  }
  if (std::error_code same; !opt.scene_file.empty() &&
                            fs::exists(dir / report::run_files::kScene) &&
                            fs::equivalent(opt.scene_file, dir / report::run_files::kScene, same)) {
    std::fprintf(stderr,
                 "dembuf: error: the scene file %s is where the run writes its resolved scene; "
                 "copy it elsewhere or choose another --out\n",
                 opt.scene_file.c_str());
    return kExitRuntime;
  }
  return std::nullopt;
}

// What a run in progress is doing, for its failure and interruption reports.
struct RunPhase {
  std::string name = "bed preparation";  ///< then "impact", then "plots"
  const FolderRecorder* recorder = nullptr;
  std::string partial() const {
    const fs::path path = recorder ? recorder->partial_samples() : fs::path();
    return path.empty() ? std::string("none") : path.string();
  }
};

// The nonce of the daemon that started this run on a cluster ("" for any other run): its
// results carry it, so that the daemon takes them as this run's.
std::string ResultNonce() {
  const char* nonce = std::getenv(report::kResultNonceVariable);
  return nonce ? nonce : "";
}

int ReportFailure(const dem::SimulationError& e, const RunPhase& phase, const Scene& scene,
                  const fs::path& dir) {
  nlohmann::json failure = {{"error", e.what()},
                            {"phase", phase.name},
                            {"step", e.step()},
                            {"time_s", e.time_s()},
                            {"scene", report::SceneToJson(scene)}};
  if (const std::string nonce = ResultNonce(); !nonce.empty())
    failure[report::kResultNonceKey] = nonce;
  report::WriteFileAtomically(dir / report::run_files::kFailure, failure.dump(2) + "\n");
  std::fprintf(stderr, "dembuf: run failed in the %s: %s\n  samples up to the failure: %s\n",
               phase.name.c_str(), e.what(), phase.partial().c_str());
  return kExitFailed;
}

int ReportInterruption(const RunPhase& phase, const fs::path& dir) {
  const bool complete = phase.name == "plots";  // the results were written before the plots
  const nlohmann::json incomplete = {{"interrupted_by", InterruptName()},
                                     {"phase", phase.name},
                                     {"complete", complete},
                                     {"samples_so_far", complete ? "" : phase.partial()}};
  report::WriteFileAtomically(dir / report::run_files::kIncomplete, incomplete.dump(2) + "\n");
  if (complete)
    std::fprintf(stderr, "dembuf: interrupted by %s while plotting; the results are complete\n",
                 InterruptName());
  else
    std::fprintf(stderr, "dembuf: interrupted by %s in the %s; %s; samples so far: %s\n",
                 InterruptName(), phase.name.c_str(),
                 phase.name == "bed preparation" ? "the bed stages done are cached"
                                                 : "marked in incomplete.json",
                 phase.partial().c_str());
  return InterruptedExit();
}

// Runs the scene into `dir` with progress lines; the summary, or an exception.
ImpactSummary RunIntoFolder(const CommandOptions& opt, const Scene& scene, BedCache& beds,
                            FolderRecorder& recorder, RunPhase& phase) {
  BedProgressLine bed_progress(stderr);
  ProgressLine progress(stderr);
  JobControl control;
  control.context = report::RunStartingNow(opt.command_line);
  control.steering.cancel = &Interrupted();
  control.on_bed_progress = [&](const BedProgress& p) { bed_progress.Update(p); };
  control.on_bed_ready = [&](const World& world) {
    for (const auto& [stage, count] : beds.prepared_counts())
      std::fprintf(stderr, "%sprepared %d %s bed(s)\n", bed_progress.open() ? "\n" : "", count,
                   stage.c_str());
    if (!world.bed.note.empty()) std::fprintf(stderr, "imported bed: %s\n", world.bed.note.c_str());
    phase.name = "impact";
  };
  control.steering.on_progress = [&](const ImpactProgress& p) { progress.Update(p); };
  try {
    const ImpactSummary summary = RunJob(scene, beds, control, recorder);
    progress.Finish();
    return summary;
  } catch (...) {
    progress.Finish();
    throw;
  }
}

}  // namespace

int RunCommand(const CommandOptions& opt) {
  ReportDestination report(opt);
  // Everything about the scene, its cost and its folder is checked before anything is
  // prepared or written.
  const Scene scene = ResolveScene(opt.scene_file, opt.preset, opt.overrides, opt.accuracy);
  PrintWarnings(SceneWarnings(scene));
  // The base scene is the paper's Table 1 with no bed (what every scene file and --set builds
  // on): a run of it alone is rarely what a new user wants, so say where the beds are.
  if (opt.scene_file.empty() && opt.preset.empty() && opt.overrides.empty() &&
      GetVerbosity() != Verbosity::kQuiet)
    std::fprintf(stderr,
                 "dembuf: no scene given: the paper's Table 1 impact on the bare plate. An impact "
                 "on a bed: dembuf run --preset e2 --set bed.thickness_m=0.02 (dembuf scene "
                 "--list presets)\n");
  if (GetVerbosity() == Verbosity::kVerbose) {
    std::cerr << "# the resolved scene\n";
    PrintScene(scene, std::cerr);
  }
  BedCache beds(BedCacheDir(opt));
  const ResourceEstimate cost = EstimateResources(scene);
  if (opt.dry_run) {
    std::printf("%s", DescribeRun(cost, beds, dem::UsableCpus()).c_str());
    return kExitDone;
  }
  const fs::path dir = opt.out_dir.empty() ? DefaultOutputDir("run") : fs::path(opt.out_dir);
  if (const std::optional<int> refused = RefuseFolder(opt, dir)) return *refused;
  CheckLocalCost({scene}, {cost}, dir, 1, beds, opt.yes);
  // The run before (replaced, or one that failed or was interrupted) goes first: whatever
  // happens to this one, nothing of that one is left to be taken for its result.
  if (opt.force || fs::exists(dir / report::run_files::kFailure) ||
      fs::exists(dir / report::run_files::kIncomplete))
    report::RemoveRunOutputs(dir);
  const bool new_folder = !fs::exists(dir);
  CatchInterrupts();
  RunPhase phase;
  std::optional<FolderRecorder> recorder;  // outlives the run: its reports name the samples
  try {
    recorder.emplace(dir, scene, opt.samples_out, ResultNonce());
    phase.recorder = &*recorder;
    const ImpactSummary summary = RunIntoFolder(opt, scene, beds, *recorder, phase);
    PrintSummary(summary, dir);
    phase.name = "plots";
    if (!opt.no_plots) PlotIfPossible(dir);
    if (Interrupted()) throw Cancelled();  // during the plots: the results are complete
    if (opt.json) {
      report.Restore();
      const nlohmann::json answer = {{"out_dir", fs::absolute(dir).string()},
                                     {"summary", recorder->summary_json()}};
      std::printf("%s\n", answer.dump(2).c_str());
    }
    return kExitDone;
  } catch (const dem::SimulationError& e) {
    return ReportFailure(e, phase, scene, dir);
  } catch (const Cancelled&) {
    return ReportInterruption(phase, dir);
  } catch (...) {
    // Anything else (the disk, say) is reported by main; a folder made for nothing goes.
    std::error_code error;
    if (new_folder && fs::is_empty(dir, error)) fs::remove(dir, error);
    throw;
  }
}

}  // namespace dembuf::cli
