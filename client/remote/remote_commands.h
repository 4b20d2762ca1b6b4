// The remote commands (submit, list, status, watch, fetch, cancel, server-info, and sweep on a
// server) and the options that name the server: remote_commands.cpp, or, in a build without
// the service, remote_absent.cpp's commands of those names that say so.
#pragma once

#include <CLI/CLI.hpp>

#include "local/commands.h"

namespace dembuf::cli {

void AddRemoteCommands(CLI::App& app, CommandOptions& options, CommandTable& commands);

}  // namespace dembuf::cli
