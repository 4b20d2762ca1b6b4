// dembuf: the command-line client. Local mode runs scenes in this process with the engine.
//
// Exit codes: 0 success, 1 usage or I/O error, 2 invalid scene, 3 simulation failed
// (unstable), 130 interrupted.
#include <CLI/CLI.hpp>
#include <atomic>
#include <csignal>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <iostream>

#include "dembuf/engine/errors.h"
#include "dembuf/engine/impact.h"
#include "dembuf/engine/scene_fields.h"
#include "dembuf/engine/version.h"
#include "progress.h"
#include "run_output.h"
#include "scene_input.h"

namespace fs = std::filesystem;
using namespace dembuf;

namespace {

constexpr int kExitUsage = 1;
constexpr int kExitBadScene = 2;
constexpr int kExitUnstable = 3;
constexpr int kExitInterrupted = 130;

std::atomic<bool> g_interrupted{false};

extern "C" void OnInterrupt(int) {
  g_interrupted.store(true);
}

fs::path DefaultOutputDir() {
  std::time_t now = std::time(nullptr);
  char stamp[32];
  std::strftime(stamp, sizeof stamp, "%Y%m%d-%H%M%S", std::gmtime(&now));
  fs::path dir = std::string("dembuf-run-") + stamp;
  for (int k = 2; fs::exists(dir); ++k)
    dir = std::string("dembuf-run-") + stamp + "-" + std::to_string(k);
  return dir;
}

struct RunOptions {
  std::string scene_file;
  std::vector<std::string> overrides;
  std::string out_dir;
  bool force = false;
};

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
  std::printf("ended at %.4f ms: %s\n", s.end_time_s * 1e3, s.end_reason.c_str());
  std::printf("wrote %s and %s\n", (dir / "plate_force.csv").c_str(),
              (dir / "summary.json").c_str());
}

int RunLocal(const RunOptions& opt) {
  // Everything about the scene is checked before anything is written.
  Scene scene = cli::ResolveScene(opt.scene_file, opt.overrides);
  World world = BuildWorld(scene);

  const fs::path dir = opt.out_dir.empty() ? DefaultOutputDir() : fs::path(opt.out_dir);
  if (fs::exists(dir / "summary.json") && !opt.force) {
    std::fprintf(stderr,
                 "dembuf: error: %s already holds a run (summary.json); choose another --out "
                 "or pass --force to replace it\n",
                 dir.c_str());
    return kExitUsage;
  }
  fs::create_directories(dir);

  cli::SampleCsvWriter csv(dir / "plate_force.csv");
  cli::ProgressLine progress(stderr);
  RunControl control;
  control.on_sample = [&](const ImpactSample& s) { csv.Write(s); };
  control.on_progress = [&](const ImpactProgress& p) { progress.Update(p); };
  control.cancel = &g_interrupted;
  std::signal(SIGINT, OnInterrupt);
  std::signal(SIGTERM, OnInterrupt);

  try {
    ImpactSummary summary = RunImpact(std::move(world), scene, control);
    progress.Finish();
    csv.Commit();
    cli::WriteFileAtomically(dir / "summary.json",
                             cli::SummaryToJson(summary, scene).dump(2) + "\n");
    PrintSummary(summary, dir);
    return 0;
  } catch (const SimulationError& e) {
    progress.Finish();
    nlohmann::json failure = {{"error", e.what()},
                              {"step", e.step()},
                              {"time_s", e.time_s()},
                              {"scene", cli::SceneToJson(scene)}};
    cli::WriteFileAtomically(dir / "failure.json", failure.dump(2) + "\n");
    std::fprintf(stderr, "dembuf: run failed: %s\n  samples up to the failure: %s\n", e.what(),
                 csv.partial_path().c_str());
    return kExitUnstable;
  } catch (const Cancelled&) {
    progress.Finish();
    std::fprintf(stderr, "dembuf: interrupted; samples so far: %s\n", csv.partial_path().c_str());
    return kExitInterrupted;
  }
}

int PrintSceneCommand(const RunOptions& opt) {
  Scene scene = cli::ResolveScene(opt.scene_file, opt.overrides);
  PrintScene(scene, std::cout);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"dembuf: DEM simulation of impacts on granular buffer layers"};
  app.set_version_flag("--version", std::string("dembuf ") + kVersion);
  app.require_subcommand(1);

  RunOptions opt;
  auto add_scene_args = [&](CLI::App* cmd) {
    cmd->add_option("scene", opt.scene_file,
                    "scene file (TOML); default: the paper's Table 1 scene");
    cmd->add_option("--set", opt.overrides,
                    "override a scene field: dotted.name=value (repeatable)")
        ->allow_extra_args(false);
  };

  CLI::App* run = app.add_subcommand("run", "run a scene locally, in this process");
  add_scene_args(run);
  run->add_option("--out", opt.out_dir, "output folder (default: dembuf-run-<UTC time>)");
  run->add_flag("--force", opt.force, "replace a run already in the output folder");

  CLI::App* scene_cmd = app.add_subcommand("scene", "show a scene with every default and unit");
  add_scene_args(scene_cmd);
  bool print_flag = false;
  scene_cmd->add_flag("--print", print_flag, "print the complete scene as TOML (the default)");

  CLI11_PARSE(app, argc, argv);

  try {
    if (run->parsed()) return RunLocal(opt);
    if (scene_cmd->parsed()) return PrintSceneCommand(opt);
  } catch (const SceneError& e) {
    std::fprintf(stderr, "dembuf: invalid scene: %s\n", e.what());
    return kExitBadScene;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "dembuf: error: %s\n", e.what());
    return kExitUsage;
  }
  return kExitUsage;
}
