// dembuf: the command-line client. Local commands (run, prepare-bed, bed export, sweep, scene,
// plot, compare) run scenes in this process with the engine; remote commands (submit, sweep,
// list, status, watch, fetch, cancel, server-info) talk to a dembufd. `sweep` goes to a daemon
// when --server or DEMBUF_SERVER names one, unless --local is given. The commands are set up
// in local_commands.cpp and remote_commands.cpp; exit codes are in exit_codes.h.
#include <CLI/CLI.hpp>
#include <cstdio>

#include "dembuf/study/files/provenance.h"
#include "dembuf/study/run/resource_estimate.h"
#include "dembuf/study/scene/errors.h"
#include "dembuf/study/text/text_limits.h"
#include "dembuf/study/version.h"
#include "local/commands.h"
#include "remote/remote_commands.h"
#include "terminal/exit_codes.h"
#include "terminal/progress.h"

using namespace dembuf;
using namespace dembuf::cli;

namespace {

// Runs the command given, turning what escapes it into a line and an exit code.
int RunCommandGiven(const CommandTable& commands) {
  try {
    return commands.RunParsed();
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
  app.footer(kExitCodesHelp);

  CommandOptions options;
  // A token given on the command line is not kept with the jobs and results it asks for.
  options.command_line = report::ShellCommandLine(argc, argv, {"--token"});
  CommandTable commands;
  AddLocalCommands(app, options, commands);
  AddRemoteCommands(app, options, commands);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help and --version end well; any other mistake in the arguments is bad input.
    return app.exit(e) == 0 ? kExitDone : kExitBadInput;
  }
  // A name is shown in tables and on terminals (and protobuf sends only UTF-8).
  if (const std::string problem = DisplayTextProblem(options.name); !problem.empty()) {
    std::fprintf(stderr, "dembuf: --name: %s\n", problem.c_str());
    return kExitBadInput;
  }
  SetVerbosity(quiet ? Verbosity::kQuiet : verbose ? Verbosity::kVerbose : Verbosity::kNormal);
  return RunCommandGiven(commands);
}
