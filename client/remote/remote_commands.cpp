// The commands that talk to a dembufd (remote.h), and the options that name it and say who
// asks. Built with the service only; remote_absent.cpp stands in for it otherwise.
#include <pwd.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>
#include <vector>

#include "remote/remote.h"
#include "remote/remote_commands.h"

namespace dembuf::cli {

namespace {

// What the remote commands read from the command line.
struct RemoteArgs {
  std::string server_flag;
  Remote remote;
  ListOptions list;
  std::int64_t id = 0;
  bool is_sweep = false;
  bool json = false;
  bool watch_csv = false;
  std::int64_t watch_from = 0;
  std::string fetch_dir;
  bool no_plots = false;
  bool fetch_force = false;
  bool fetch_long = false;
};

// Who this process runs as, one rule for the CLI and the Python package: $USER, else
// $LOGNAME, else the name of its user id, else "anonymous" (a container's uid may have none).
std::string LocalUserName() {
  for (const char* name : {"USER", "LOGNAME"})
    if (const char* value = std::getenv(name); value && *value) return value;
  std::vector<char> buf(16384);
  passwd entry{};
  passwd* found = nullptr;
  if (getpwuid_r(getuid(), &entry, buf.data(), buf.size(), &found) == 0 && found &&
      found->pw_name && *found->pw_name)
    return found->pw_name;
  return "anonymous";
}

// The server's address, the token and the TLS trust from the environment where the command
// line gives none. A token says who the user is; without one (a loopback daemon trusting its
// machine) the owner is --owner, else $USER.
void CompleteFromEnvironment(RemoteArgs& args, const std::string& command_line) {
  Remote& remote = args.remote;
  remote.address = ServerAddress(args.server_flag);
  remote.command_line = command_line;
  auto from_env = [](std::string& value, const char* name) {
    if (const char* env = std::getenv(name); value.empty() && env && *env) value = env;
  };
  from_env(remote.token, "DEMBUF_TOKEN");
  from_env(remote.tls_ca, "DEMBUF_TLS_CA");
  if (remote.owner.empty() && remote.token.empty()) remote.owner = LocalUserName();
}

RemoteScene SceneOf(const CommandOptions& opt) {
  return {opt.scene_file, opt.preset, opt.accuracy, opt.overrides};
}

void AddJobCommands(CLI::App& app, CommandOptions& opt, RemoteArgs& a, CommandTable& commands) {
  CLI::App* submit = app.add_subcommand("submit", "queue a scene on the server; prints the job id");
  AddSceneArguments(submit, opt);
  submit->add_option("--name", opt.name, "a name for the job");
  submit->add_flag("--notify", opt.notify,
                   "post to the lab's chat when the job has ended (the daemon's hook; dembuf "
                   "server-info says whether it has one)");
  submit->add_flag("--no-reuse", opt.no_reuse,
                   "run it even when a stored result of the same scene, seed, bed file and "
                   "engine could answer it at once");
  commands.Add(submit, [&] {
    return RemoteSubmit(a.remote, SceneOf(opt), {opt.name, opt.notify, opt.no_reuse});
  });

  CLI::App* list = app.add_subcommand("list", "list the server's jobs (or sweeps), newest first");
  list->add_option("--state", a.list.state,
                   "only jobs in this state: queued, preparing_bed, running, done, failed, "
                   "cancelled");
  list->add_option("--owner", a.list.owner, "only this owner's");
  list->add_option("--sweep", a.list.sweep, "only this sweep's jobs");
  list->add_option("--limit", a.list.limit, "at most this many (default 20)");
  list->add_flag("--sweeps", a.list.sweeps, "list sweeps instead of jobs");
  list->add_flag("--json", a.list.json, "print JSON (docs/service.md) instead of a table");
  commands.Add(list, [&] { return RemoteList(a.remote, a.list); });

  CLI::App* status = app.add_subcommand("status", "a job's state, progress and results");
  status->add_option("id", a.id, "job id (or sweep id with --sweep)")->required();
  status->add_flag("--sweep", a.is_sweep, "the id is a sweep's");
  status->add_flag("--json", a.json, "print JSON (docs/service.md) instead of text");
  commands.Add(status, [&] { return RemoteStatus(a.remote, a.id, a.is_sweep, a.json); });

  CLI::App* watch = app.add_subcommand("watch", "follow a job's plate force live (or a sweep)");
  watch->add_option("id", a.id, "job id (or sweep id with --sweep)")->required();
  watch->add_flag("--csv", a.watch_csv, "print every sample as a CSV row");
  watch->add_option("--from", a.watch_from, "first sample index (to resume)");
  watch->add_flag("--sweep", a.is_sweep,
                  "follow a sweep: a line as its jobs end, and exit when all have (0: all done; "
                  "3: one failed; 4: one was cancelled)");
  commands.Add(watch, [&] {
    return a.is_sweep ? RemoteWatchSweep(a.remote, a.id)
                      : RemoteWatch(a.remote, a.id, a.watch_csv, a.watch_from);
  });
}

void AddResultCommands(CLI::App& app, RemoteArgs& a, CommandTable& commands) {
  CLI::App* fetch = app.add_subcommand(
      "fetch", "write a finished job's files (summary.json, plate_force.csv, ...) or a sweep's");
  fetch->add_option("id", a.id, "job id (or sweep id with --sweep)")->required();
  fetch->add_flag("--sweep", a.is_sweep, "the id is a sweep's");
  fetch->add_option("--out", a.fetch_dir, "output folder")->required();
  fetch->add_flag("--no-plots", a.no_plots, "do not draw plots");
  fetch->add_flag("--force", a.fetch_force, "replace what an earlier fetch wrote into the folder");
  fetch->add_flag("--long", a.fetch_long,
                  "with --sweep: also every sample of every run as one tidy table, "
                  "sweep_long.csv (run, the swept fields, then plate_force.csv's columns)");
  commands.Add(fetch, [&] {
    return RemoteFetch(a.remote, a.id, a.is_sweep, a.fetch_dir, !a.no_plots, a.fetch_force,
                       a.fetch_long);
  });

  CLI::App* cancel = app.add_subcommand("cancel", "cancel a queued or running job (or sweep)");
  cancel->add_option("id", a.id, "job id (or sweep id with --sweep)")->required();
  cancel->add_flag("--sweep", a.is_sweep, "cancel every unfinished job of the sweep");
  commands.Add(cancel, [&] { return RemoteCancel(a.remote, a.id, a.is_sweep); });
  CLI::App* del = app.add_subcommand(
      "delete",
      "delete an ended job (or sweep) and its stored results, which count against "
      "your quota on the server");
  del->add_option("id", a.id, "job id (or sweep id with --sweep)")->required();
  del->add_flag("--sweep", a.is_sweep, "delete the sweep and every job of it (all ended)");
  commands.Add(del, [&] { return RemoteDelete(a.remote, a.id, a.is_sweep); });

  CLI::App* info = app.add_subcommand("server-info", "the server's version, workers and queue");
  info->add_flag("--json", a.json, "print JSON (docs/service.md) instead of text");
  commands.Add(info, [&] { return RemoteServerInfo(a.remote, a.json); });
}

// Under `dembuf bed` (local_commands.cpp), beside export.
void AddBedPush(CLI::App& app, CommandOptions& opt, RemoteArgs& a, CommandTable& commands) {
  CLI::App* push = app.get_subcommand("bed")->add_subcommand(
      "push",
      "put a scene's prepared beds from the local bed cache into the server's (admins), so "
      "that its jobs do not prepare them again");
  AddSceneArguments(push, opt);
  push->add_option("--bed-cache", opt.bed_cache, "folder of prepared beds (default: the user's)");
  commands.Add(push,
               [&] { return RemotePushBeds(a.remote, SceneOf(opt), BedCacheDir(opt).string()); });
}

}  // namespace

void AddRemoteCommands(CLI::App& app, CommandOptions& opt, CommandTable& commands) {
  // The arguments live as long as the commands that read them (they run after main's parse).
  const auto args = std::make_shared<RemoteArgs>();
  app.add_option("--server", args->server_flag,
                 "dembufd address host:port (default: $DEMBUF_SERVER, else 127.0.0.1:50051)");
  app.add_option("--owner", args->remote.owner, "owner of submitted jobs (default: $USER)");
  app.add_option("--token", args->remote.token,
                 "API token of a server that needs one (default: $DEMBUF_TOKEN)");
  app.add_option("--tls-ca", args->remote.tls_ca,
                 "speak TLS, trusting this PEM certificate (default: $DEMBUF_TLS_CA)");
  AddJobCommands(app, opt, *args, commands);
  AddResultCommands(app, *args, commands);
  AddBedPush(app, opt, *args, commands);
  // After the parse, before any command runs.
  app.parse_complete_callback([args, &opt] { CompleteFromEnvironment(*args, opt.command_line); });
  commands.sweep_elsewhere = [args](const CommandOptions& o) -> std::optional<int> {
    if (o.local || !ServerGiven(args->server_flag)) return std::nullopt;
    // A dry run submits nothing: it plans here, on this machine's CPUs or --plan-cpus.
    if (o.dry_run) {
      std::fprintf(stderr,
                   "dembuf: a dry run is planned here, not on the server (--plan-cpus N plans "
                   "for the server's N CPUs; --local runs the sweep here)\n");
      return std::nullopt;
    }
    if (o.long_table) {
      std::fprintf(stderr,
                   "dembuf: --long is written when a server's sweep is fetched: dembuf fetch "
                   "--sweep ID --long --out DIR (--local runs the sweep here)\n");
      return kExitBadInput;
    }
    return RemoteSweep(args->remote, SceneOf(o), o.vary, o.table, o.seeds,
                       {o.name, o.notify, o.no_reuse}, o.json);
  };
}

}  // namespace dembuf::cli
