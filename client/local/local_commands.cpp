// The commands that run here, in this process: their arguments and the helpers they share.
#include <fcntl.h>
#include <unistd.h>

#include <cstdio>
#include <ctime>
#include <iostream>
#include <thread>

#include "dembuf/study/files/bed_export.h"
#include "dembuf/study/scene/presets.h"
#include "dembuf/study/scene/scene_fields.h"
#include "local/commands.h"
#include "local/compare.h"
#include "local/plots.h"
#include "local/scene_input.h"
#include "terminal/exit_codes.h"
#include "terminal/progress.h"

namespace dembuf::cli {

namespace fs = std::filesystem;

void CommandTable::Add(CLI::App* command, std::function<int()> run) {
  m_commands.emplace_back(command, std::move(run));
}

int CommandTable::RunParsed() const {
  for (const auto& [command, run] : m_commands)
    if (command->parsed()) return run();
  return kExitRuntime;
}

void AddSceneArguments(CLI::App* command, CommandOptions& opt) {
  command->add_option("scene", opt.scene_file,
                      "scene file (TOML); default: the paper's Table 1 scene");
  // The presets named from their list, so that a new one cannot be left out of the help.
  std::string presets;
  for (const Preset& p : Presets()) presets += (presets.empty() ? "" : ", ") + std::string(p.name);
  command->add_option("--preset", opt.preset,
                      "start from a preset scene (scenes/*.toml): " + presets);
  command->add_option("--accuracy", opt.accuracy,
                      "draft, standard or reference: time step and settling tolerance together "
                      "(docs/accuracy-cost.md)");
  command
      ->add_option("--set", opt.overrides, "override a scene field: dotted.name=value (repeatable)")
      ->allow_extra_args(false);
}

namespace {

constexpr const char* kBedCacheHelp = "folder of prepared beds (default ~/.cache/dembuf/beds)";

void AddRun(CLI::App& app, CommandOptions& opt, CommandTable& commands) {
  CLI::App* run = app.add_subcommand("run", "run a scene locally, in this process");
  AddSceneArguments(run, opt);
  run->add_option("--out", opt.out_dir, "output folder (default: dembuf-run-<UTC time>)");
  run->add_flag("--force", opt.force, "replace a run already in the output folder");
  run->add_option("--bed-cache", opt.bed_cache, kBedCacheHelp);
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
  commands.Add(run, [&opt] { return RunCommand(opt); });
}

void AddBedCommands(CLI::App& app, CommandOptions& opt, CommandTable& commands) {
  CLI::App* prepare_bed = app.add_subcommand(
      "prepare-bed", "prepare a scene's bed into the bed cache, without the impact");
  AddSceneArguments(prepare_bed, opt);
  prepare_bed->add_option("--bed-cache", opt.bed_cache, kBedCacheHelp);
  prepare_bed->add_flag("--source-only", opt.source_only,
                        "only the settled source bed that the bed is cut from");
  commands.Add(prepare_bed, [&opt] { return PrepareBedCommand(opt); });

  CLI::App* bed = app.add_subcommand("bed", "beds for other programs and for a server");
  bed->alias("beds");
  bed->require_subcommand(1);
  CLI::App* bed_export = bed->add_subcommand(
      "export",
      "write a scene's bed (from the bed cache, prepared first if need be) for ParaView, "
      "LAMMPS or Yade, or to import again");
  AddSceneArguments(bed_export, opt);
  bed_export->add_option("--bed-cache", opt.bed_cache, kBedCacheHelp);
  bed_export->add_flag("--source-only", opt.source_only,
                       "the settled source bed that the bed is cut from");
  // The choices and their help from the one list of formats.
  std::vector<std::string> formats;
  std::string format_help;
  for (const BedFormatName& f : BedFormatNames()) {
    formats.emplace_back(f.name);
    format_help +=
        (format_help.empty() ? "" : ", ") + std::string(f.name) + " (" + std::string(f.help) + ")";
  }
  bed_export->add_option("--format", opt.export_format, format_help)
      ->check(CLI::IsMember(formats))
      ->required();
  bed_export->add_option("--out", opt.export_out, "the file to write")->required();
  bed_export->add_flag("--force", opt.force, "replace the file if it exists");
  commands.Add(bed_export, [&opt] { return ExportBedCommand(opt); });
}

void AddSweep(CLI::App& app, CommandOptions& opt, CommandTable& commands) {
  CLI::App* sweep = app.add_subcommand("sweep", "run a scene over ranges of fields and seeds");
  AddSceneArguments(sweep, opt);
  sweep
      ->add_option("--vary", opt.vary,
                   "dotted.field=START:STOP:STEP or dotted.field=v1,v2,... (repeatable)")
      ->allow_extra_args(false);
  sweep->add_option("--table", opt.table,
                    "a file of chosen points: a header of field names, then a row of values per "
                    "point, tab- or comma-separated (bed.seed may be a column; else --seeds); "
                    "multiplied by each --vary");
  sweep->add_flag("--long", opt.long_table,
                  "also write every sample of every run as one tidy table, sweep_long.csv "
                  "(run, the swept fields, then plate_force.csv's columns)");
  sweep->add_option("--find-hc", opt.find_hc,
                    "LOW:HIGH[:TOL] (m): find Hc by bisection of bed.thickness_m in that range "
                    "(P within 10% of its value at HIGH), to TOL (default 0.001)");
  sweep->add_option("--seeds", opt.seeds,
                    "N bed seeds for every point, from bed.seed on (default 1)");
  sweep->add_option(
      "--jobs", opt.jobs,
      "runs at once (default 0: one per CPU this process may use, never more); the cores are "
      "shared among the runs going by what their beds can feed, a run that others wait for "
      "first");
  sweep->add_option("--plan-cpus", opt.plan_cpus,
                    "with --dry-run: plan for this many CPUs instead of this machine's (a lab "
                    "server's, a cluster node's), 1 to 1024");
  sweep->add_option("--out", opt.out_dir, "output folder (default: dembuf-sweep-<UTC time>)");
  sweep->add_flag("--force", opt.force,
                  "replace another sweep's runs in the output folder (the same sweep resumes)");
  sweep->add_option("--bed-cache", opt.bed_cache, "folder of prepared beds");
  sweep->add_flag("--no-bed-cache", opt.no_bed_cache, "keep prepared beds in memory only");
  sweep->add_flag("--dry-run", opt.dry_run, "print what the sweep would cost and stop");
  sweep->add_flag("--yes", opt.yes, "run even when the estimate passes this machine's limits");
  sweep->add_flag("--local", opt.local, "run here even when a server is configured");
  sweep->add_flag("--json", opt.json,
                  "print the result as JSON on stdout (locally: the folder, the failed runs and "
                  "summary.json; on a server: the sweep and its job ids), the report on stderr");
  sweep->add_option("--name", opt.name, "a name for the sweep (remote)");
  sweep->add_flag("--notify", opt.notify,
                  "with --server or DEMBUF_SERVER: post to the lab's chat when the sweep has "
                  "ended (the daemon's hook; dembuf server-info says whether it has one)");
  sweep->add_flag("--no-reuse", opt.no_reuse,
                  "on a server: run every point, even one a stored result of the same scene, "
                  "seed, bed file and engine could answer at once (here, a folder's runs done "
                  "are kept unless --force)");
  commands.Add(sweep, [&opt, &commands] {
    if (commands.sweep_elsewhere)
      if (const std::optional<int> code = commands.sweep_elsewhere(opt)) return *code;
    if (opt.notify) {
      std::fprintf(stderr,
                   "dembuf: --notify asks a server's chat hook; a sweep run here ends in this "
                   "terminal (name a server with --server or DEMBUF_SERVER)\n");
      return static_cast<int>(kExitBadInput);
    }
    return SweepCommand(opt);
  });
}

// `dembuf scene --list WHAT`: what --set, --preset, --accuracy and --format take, for people,
// the shell's completion and the manual page. A field's line: its name, then its unit, range,
// meaning and what it shapes (the earliest stage of a run it enters, from the field table),
// tab-separated.
int ListValues(const std::string& what) {
  if (what == "presets")
    for (const Preset& p : Presets())
      std::printf("%.*s\t%s\n", int(p.name.size()), p.name.data(), PresetSummary(p).c_str());
  if (what == "accuracies")
    for (const AccuracyPreset& a : AccuracyPresets())
      std::printf("%.*s\t%.*s\n", int(a.name.size()), a.name.data(), int(a.description.size()),
                  a.description.data());
  if (what == "formats")
    for (const BedFormatName& f : BedFormatNames())
      std::printf("%.*s\t%.*s\n", int(f.name.size()), f.name.data(), int(f.help.size()),
                  f.help.data());
  if (what != "fields") return 0;
  for (const SceneField& f : SceneFields()) {
    std::string range;
    if (!f.choices.empty()) {
      for (const std::string_view c : f.choices)
        range += (range.empty() ? "" : "|") + std::string(c);
    } else if (f.max > f.min) {
      char text[96];
      std::snprintf(text, sizeof text, "%s%g to %g%s", f.min_open ? "(" : "[", f.min, f.max,
                    f.max_open ? ")" : "]");
      range = text;
    } else if (std::holds_alternative<bool& (*)(Scene&)>(f.ref)) {
      range = "true|false";
    } else if (std::holds_alternative<std::string& (*)(Scene&)>(f.ref)) {
      range = "text";
    }
    const std::string_view shapes = ShapesName(f.shapes);
    std::printf("%.*s\t%.*s\t%s\t%.*s\t%.*s\n", int(f.name.size()), f.name.data(),
                int(f.unit.size()), f.unit.data(), range.c_str(), int(f.help.size()), f.help.data(),
                int(shapes.size()), shapes.data());
  }
  return 0;
}

// The commands that read folders and scenes: plot, compare and scene.
void AddReaders(CLI::App& app, CommandOptions& opt, CommandTable& commands) {
  CLI::App* plot = app.add_subcommand("plot", "draw PNG plots of a run or sweep folder (gnuplot)");
  auto plot_dir = std::make_shared<std::string>();
  plot->add_option("folder", *plot_dir, "a run or sweep output folder")->required();
  commands.Add(plot, [plot_dir] {
    for (const auto& file : PlotFolder(*plot_dir)) std::printf("%s\n", file.c_str());
    return 0;
  });

  CLI::App* compare = app.add_subcommand(
      "compare", "put runs or sweeps beside the paper's numbers and the Hertz bare-plate peak");
  struct CompareArgs {
    std::vector<std::string> folders;
    std::string out;
    bool no_plots = false;
  };
  auto args = std::make_shared<CompareArgs>();
  compare->add_option("folders", args->folders, "run or sweep output folders")->required();
  compare->add_option("--out", args->out, "where compare.csv goes (default: the first folder)");
  compare->add_flag("--no-plots", args->no_plots, "do not draw compare.png");
  commands.Add(compare, [args] {
    return CompareCommand({args->folders.begin(), args->folders.end()}, args->out, !args->no_plots);
  });

  CLI::App* scene = app.add_subcommand("scene", "show a scene with every default and unit");
  AddSceneArguments(scene, opt);
  static bool print_flag = false;  // the default; the flag says it aloud
  scene->add_flag("--print", print_flag, "print the complete scene as TOML (the default)");
  static std::string list;
  scene
      ->add_option("--list", list,
                   "list the values an option takes, one a line: fields (every scene field, "
                   "with its unit, range, meaning and the stage it shapes), presets, "
                   "accuracies or formats")
      ->check(CLI::IsMember({"fields", "presets", "accuracies", "formats"}));
  commands.Add(scene, [&opt] {
    if (!list.empty()) return ListValues(list);
    const Scene resolved = ResolveScene(opt.scene_file, opt.preset, opt.overrides, opt.accuracy);
    PrintWarnings(SceneWarnings(resolved));
    PrintScene(resolved, std::cout);
    return 0;
  });
}

}  // namespace

void AddLocalCommands(CLI::App& app, CommandOptions& opt, CommandTable& commands) {
  AddRun(app, opt, commands);
  AddBedCommands(app, opt, commands);
  AddSweep(app, opt, commands);
  AddReaders(app, opt, commands);
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

fs::path BedCacheDir(const CommandOptions& opt) {
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

ReportDestination::ReportDestination(const CommandOptions& opt) {
  if (GetVerbosity() != Verbosity::kQuiet && !opt.json) return;  // stdout stays
  std::fflush(stdout);
  const int target =
      GetVerbosity() == Verbosity::kQuiet ? open("/dev/null", O_WRONLY) : dup(STDERR_FILENO);
  if (target < 0) return;
  m_saved = dup(STDOUT_FILENO);
  if (m_saved >= 0) dup2(target, STDOUT_FILENO);
  close(target);
}

void ReportDestination::Restore() {
  if (m_saved < 0) return;
  std::fflush(stdout);
  dup2(m_saved, STDOUT_FILENO);
  close(m_saved);
  m_saved = -1;
}

}  // namespace dembuf::cli
