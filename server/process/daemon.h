// dembufd's start-up, each part a function of its own: the arguments (a configuration file,
// then the flags given), the token commands and the database check (which work on the
// database and start nothing), and serving: the lock, the store, the executor, the gRPC server
// and the web pages, until a stop signal.
#pragma once

#include <CLI/CLI.hpp>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "process/config.h"

namespace dembuf::server {

/// dembufd's exit codes.
enum DaemonExit : int {
  kDaemonDone = 0,      ///< a clean shutdown (SIGTERM, SIGINT, SIGHUP), or a command done
  kDaemonRuntime = 1,   ///< a database or address that cannot be used, a damaged database
  kDaemonBadInput = 2,  ///< bad flags or settings
};

/// The reflection streams served at once (each holds a thread of gRPC's pool).
inline constexpr int kReflectionStreams = 16;

/// What the command line asked for.
struct DaemonArgs {
  std::string config_file;
  ServerConfig flags;   ///< the flags' values; only those given override the file
  std::string workers;  ///< --workers as given ("auto" or a number)
  std::vector<std::pair<const CLI::Option*, std::function<void(ServerConfig&)>>> given;
  CLI::App* token_create = nullptr;
  CLI::App* token_revoke = nullptr;
  CLI::App* token_list = nullptr;
  std::string user;
  bool admin = false;
  bool check_db = false;
  bool check_config = false;
  std::vector<std::string> settings;  ///< --setting KEY=VALUE, in order
};

/// Declares dembufd's options and commands on `app`, read into `args`.
void SetupDaemonArgs(CLI::App& app, DaemonArgs& args);
/// The configuration: the file's, then each flag given. Throws ConfigError.
ServerConfig ResolveConfig(const DaemonArgs& args);

/// token-create, token-revoke or token-list on the configured database.
int TokenCommand(const ServerConfig& config, const DaemonArgs& args);
/// --check-config: the settings resolved and checked, printed as a configuration file.
int CheckConfig(const ServerConfig& config);
/// --check-db: the database checked offline against its checksums.
int CheckDatabase(const ServerConfig& config);
/// Serves until a stop signal; the exit code.
int Serve(const ServerConfig& config);

}  // namespace dembuf::server
