// dembufd's arguments, and the commands that work on the database without serving.
#include <sys/stat.h>

#include <cstdio>
#include <iostream>

#include "access/auth.h"
#include "dembuf/study/version.h"
#include "process/daemon.h"
#include "process/instance.h"
#include "process/secret_file.h"
#include "store/store.h"

namespace dembuf::server {

namespace {

// A flag that overrides one setting of the configuration file when given.
template <typename T>
void AddSetting(CLI::App& app, DaemonArgs& args, const char* name, T ServerConfig::*setting,
                const char* help) {
  const CLI::Option* option = app.add_option(name, args.flags.*setting, help);
  args.given.emplace_back(
      option, [setting, &args](ServerConfig& config) { config.*setting = args.flags.*setting; });
}

}  // namespace

void SetupDaemonArgs(CLI::App& app, DaemonArgs& args) {
  app.set_version_flag("--version", std::string("dembufd ") + dembuf::kVersion);
  app.add_option("--config", args.config_file, "TOML configuration file (flags override it)")
      ->check(CLI::ExistingFile);
  AddSetting(app, args, "--listen", &ServerConfig::listen, "address to serve, host:port");
  AddSetting(app, args, "--db", &ServerConfig::db,
             "SQLite database file (created if absent), in a folder of the daemon's own account "
             "that no other account may write");
  const CLI::Option* workers =
      app.add_option("--workers", args.workers,
                     "jobs run at once: 1 to 256, or auto (one per usable CPU; the default)");
  args.given.emplace_back(
      workers, [&args](ServerConfig& config) { config.workers = ParseWorkers(args.workers); });
  AddSetting(app, args, "--threads-per-job", &ServerConfig::threads_per_job,
             "engine threads per job (0: cores / workers)");
  AddSetting(app, args, "--queue-limit", &ServerConfig::queue_limit, "queued jobs at most");
  AddSetting(app, args, "--log-file", &ServerConfig::log_file, "also log to this file");
  AddSetting(app, args, "--log-level", &ServerConfig::log_level,
             "trace, debug, info, warn, error, critical or off");
  AddSetting(app, args, "--shutdown-grace", &ServerConfig::shutdown_grace_s,
             "seconds SIGTERM waits for running jobs before requeueing them");
  AddSetting(app, args, "--storage-retry", &ServerConfig::storage_retry_s,
             "seconds to wait before the next job once the disk was full");
  AddSetting(app, args, "--http", &ServerConfig::http,
             "also serve the web pages on HOST:PORT (a port alone: on loopback); off unless set");
  AddSetting(app, args, "--access", &ServerConfig::access,
             "who may call: tokens (every request carries a user's token; the default) or local "
             "(a call without a token is this machine's trusted user, an admin; every address "
             "must be on loopback)");
  AddSetting(app, args, "--executor", &ServerConfig::executor,
             "where jobs run: threads (this machine) or slurm (the cluster of the "
             "configuration's [slurm] table)");
  app.add_option("--setting", args.settings,
                 "any setting of the configuration file as KEY=VALUE (slurm.KEY for its [slurm] "
                 "table; repeatable): --setting quota_beads=2e6 --setting slurm.partition=debug; "
                 "the named flags above override it");
  app.add_flag("--check-config", args.check_config,
               "check the configuration (file, --setting and flags), print every setting as a "
               "configuration file would, and exit: 0 valid, 2 not");
  // Token administration: works on the database, does not start the server.
  args.token_create = app.add_subcommand("token-create", "make (or replace) a user's API token");
  args.token_create->add_option("name", args.user, "user name")->required();
  args.token_create->add_flag("--admin", args.admin, "the user sees and cancels every job");
  args.token_revoke = app.add_subcommand("token-revoke", "remove a user's API token");
  args.token_revoke->add_option("name", args.user, "user name")->required();
  args.token_list = app.add_subcommand("token-list", "list the users that have tokens");
  app.add_flag("--check-db", args.check_db,
               "verify the database offline (SQLite's integrity check, then every stored "
               "summary, series and result file against its checksum), reading only, and exit: "
               "0 intact, 1 damaged or not verifiable (an older database is reported as such, "
               "and left as it is); refused while a daemon uses it");
}

ServerConfig ResolveConfig(const DaemonArgs& args) {
  ServerConfig config;
  if (!args.config_file.empty()) LoadConfigFile(args.config_file, config);
  for (const std::string& setting : args.settings) ApplySettingFlag(setting, config);
  for (const auto& [option, set] : args.given)
    if (option->count() > 0) set(config);
  ValidateConfig(config);
  return config;
}

int TokenCommand(const ServerConfig& config, const DaemonArgs& args) {
  try {
    // The daemon's database, in its folder: run as its account (sudo -u dembuf ...).
    CheckDatabaseFiles(config.db);
    Store store(config.db);
    if (args.token_create->parsed()) {
      if (const std::string problem = UserNameProblem(args.user); !problem.empty()) {
        std::cerr << "dembufd: name: " << problem << "\n";
        return kDaemonBadInput;
      }
      const std::string token = NewToken();
      store.SetUser(args.user, HashToken(token), args.admin);
      std::printf("%s\n", token.c_str());
      std::fprintf(stderr,
                   "token for %s%s (shown once; the database keeps only its hash); the "
                   "user sets DEMBUF_TOKEN to it\n",
                   args.user.c_str(), args.admin ? " (admin)" : "");
    } else if (args.token_revoke->parsed()) {
      if (!store.RemoveUser(args.user)) throw std::runtime_error("no user " + args.user);
      std::fprintf(stderr, "token of %s removed\n", args.user.c_str());
    } else {
      for (const User& u : store.ListUsers())
        std::printf("%s%s\n", u.name.c_str(), u.admin ? " (admin)" : "");
    }
    return kDaemonDone;
  } catch (const std::exception& e) {
    std::cerr << "dembufd: " << e.what() << "\n";
    return kDaemonRuntime;
  }
}

int CheckConfig(const ServerConfig& config) {
  // The files the settings name that the daemon reads as it starts.
  if (!config.notify_url_file.empty()) {
    try {
      ReadHookUrl(config.notify_url_file);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "dembufd: %s\n", e.what());
      return kDaemonBadInput;
    }
  }
  std::printf("%s", ConfigText(config).c_str());
  std::fprintf(stderr, "dembufd: the configuration is valid\n");
  return kDaemonDone;
}

int CheckDatabase(const ServerConfig& config) {
  try {
    // The lock first: the check reads a database no daemon is changing. Read only: a check
    // changes nothing, and finds what is there (it upgraded an old database, writing
    // checksums over whatever it held, and called that intact).
    DatabaseLock lock(config.db, /*create=*/false);
    StoreOptions read_only;
    read_only.read_only = true;
    Store store(config.db, read_only);
    const std::string older = store.schema_version() < Store::CurrentSchemaVersion()
                                  ? " (schema version " + std::to_string(store.schema_version()) +
                                        ", older than this dembufd's " +
                                        std::to_string(Store::CurrentSchemaVersion()) +
                                        ": left as it is; dembufd upgrades it at its next start)"
                                  : "";
    if (!store.HasChecksums()) {
      std::printf(
          "database %s: SQLite's integrity check passed, but its results have no checksums to "
          "check%s: not verified\n",
          config.db.c_str(), older.c_str());
      return kDaemonRuntime;
    }
    const CheckReport report = store.Check();
    for (const std::string& problem : report.problems) std::printf("%s\n", problem.c_str());
    std::printf(
        "database %s%s: %lld summaries, %lld series chunks and %lld result files checked: %s\n",
        config.db.c_str(), older.c_str(), static_cast<long long>(report.summaries),
        static_cast<long long>(report.series_chunks), static_cast<long long>(report.files),
        report.problems.empty() ? "intact"
                                : (std::to_string(report.problems.size()) + " damaged").c_str());
    return report.problems.empty() ? kDaemonDone : kDaemonRuntime;
  } catch (const std::exception& e) {
    std::cerr << "dembufd: " << e.what() << "\n";
    return kDaemonRuntime;
  }
}

}  // namespace dembuf::server
