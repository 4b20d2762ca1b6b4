// dembuf's local commands (run, prepare-bed, bed export, sweep, scene, plot, compare) and what
// every command shares: the options, the table of commands. main() builds the CLI11
// application and asks each group to add its commands: these, then the remote ones
// (remote/remote_commands.h).
#pragma once

#include <CLI/CLI.hpp>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace dembuf::cli {

/// The options of every command, as CLI11 fills them (a command reads the groups it has: the
/// scene arguments, the output, the bed cache, a sweep's axes, a bed export's file).
struct CommandOptions {
  std::string scene_file;
  std::string preset;
  std::string accuracy;
  std::vector<std::string> overrides;
  std::string out_dir;
  bool force = false;
  std::string bed_cache;
  bool no_bed_cache = false;
  std::vector<std::string> vary;
  std::string table;        ///< sweep --table: a file of chosen points (ParseSweepTable)
  bool long_table = false;  ///< sweep --long: also sweep_long.csv (WriteSweepLongTable)
  std::string find_hc;      ///< "LOW:HIGH[:TOLERANCE]" in metres: dembuf sweep --find-hc
  int seeds = 1;
  int jobs = 0;       ///< sweep runs at once; 0: one per usable CPU
  int plan_cpus = 0;  ///< sweep --dry-run: plan for this many CPUs (0: this machine's)
  bool local = false;
  std::string name;
  bool notify = false;      ///< submit, sweep on a server: the daemon's chat hook tells of the end
  bool no_reuse = false;    ///< submit, sweep on a server: run even where a stored result answers
  std::string samples_out;  ///< also stream the samples, packed, to this file
  bool no_plots = false;
  bool source_only = false;   ///< prepare-bed: only the source bed
  bool dry_run = false;       ///< print the estimate and stop
  bool yes = false;           ///< run even past this machine's limits
  bool json = false;          ///< print the result as JSON on stdout, the rest on stderr
  std::string command_line;   ///< this program's arguments, for the results' provenance
  std::string export_format;  ///< bed export: a name of BedFormatNames()
  std::string export_out;     ///< bed export: the file
};

/// The commands added, each with what runs it when it was the one given.
class CommandTable {
 public:
  void Add(CLI::App* command, std::function<int()> run);
  /// Runs the command given (kExitRuntime when none was).
  int RunParsed() const;
  /// Set by the remote commands: runs a sweep on a server when one is named and --local is
  /// not given (nothing otherwise, and then the sweep runs here).
  std::function<std::optional<int>(const CommandOptions&)> sweep_elsewhere;

 private:
  std::vector<std::pair<CLI::App*, std::function<int()>>> m_commands;
};

/// The scene arguments of a command: the file, --preset, --accuracy, --set.
void AddSceneArguments(CLI::App* command, CommandOptions& options);

/// run, prepare-bed, bed export, sweep, scene, plot and compare (local_commands.cpp).
void AddLocalCommands(CLI::App& app, CommandOptions& options, CommandTable& commands);

// The larger local commands, in files of their own.
int RunCommand(const CommandOptions& options);         // run_command.cpp
int PrepareBedCommand(const CommandOptions& options);  // bed_commands.cpp
int ExportBedCommand(const CommandOptions& options);   // bed_commands.cpp
int SweepCommand(const CommandOptions& options);       // sweep_command.cpp

// What the local commands share (local_commands.cpp).

/// Where prepared beds are kept: --bed-cache, $DEMBUF_BED_CACHE, $XDG_CACHE_HOME/dembuf/beds or
/// ~/.cache/dembuf/beds; none with --no-bed-cache.
std::filesystem::path BedCacheDir(const CommandOptions& options);
/// A new folder "dembuf-KIND-<UTC time>" (with "-2", "-3", ... when taken).
std::filesystem::path DefaultOutputDir(const std::string& kind);
void PrintWarnings(const std::vector<std::string>& warnings);

/// Where the report for people goes: stdout (the default), stderr (with --json, so that stdout
/// carries the JSON alone) or nowhere (-q); the report's own prints and gnuplot's too.
class ReportDestination {
 public:
  explicit ReportDestination(const CommandOptions& options);
  ReportDestination(const ReportDestination&) = delete;
  ReportDestination& operator=(const ReportDestination&) = delete;
  ~ReportDestination() { Restore(); }
  /// Stdout is stdout again (for the JSON).
  void Restore();

 private:
  int m_saved = -1;
};

}  // namespace dembuf::cli
