// dembufd: the dembuf daemon. Serves the gRPC API of proto/dembuf/v1, keeps everything in one
// SQLite database and runs the queued jobs on a pool of workers. The start-up is in daemon.h;
// exit codes: 0 after a clean shutdown (SIGTERM, SIGINT or SIGHUP), 1 when a database or
// address cannot be used (or another runtime failure), 2 for bad flags or settings.
#include <sys/stat.h>

#include <CLI/CLI.hpp>
#include <iostream>

#include "process/daemon.h"

using namespace dembuf::server;

int main(int argc, char** argv) {
  CLI::App app{"dembufd: the dembuf daemon (gRPC API, job queue, SQLite store)"};
  DaemonArgs args;
  SetupDaemonArgs(app, args);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help and --version end the program well; any other parse error is bad input.
    return app.exit(e) == 0 ? kDaemonDone : kDaemonBadInput;
  }
  // Everything the daemon creates (the database, its side files, logs, results, a unix
  // socket) is its own account's alone: the database holds every user's work.
  umask(0077);
  ServerConfig config;
  try {
    config = ResolveConfig(args);
  } catch (const ConfigError& e) {
    std::cerr << "dembufd: " << e.what() << "\n";
    return kDaemonBadInput;
  }
  if (args.token_create->parsed() || args.token_revoke->parsed() || args.token_list->parsed())
    return TokenCommand(config, args);
  if (args.check_config) return CheckConfig(config);
  if (args.check_db) return CheckDatabase(config);
  return Serve(config);
}
