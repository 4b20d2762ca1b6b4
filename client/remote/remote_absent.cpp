// In a build without the service (cmake -DDEMBUF_SERVICE=OFF) the remote commands do not
// exist: each of their names answers why, instead of CLI11's "a subcommand is required".
#include <cstdio>
#include <string_view>

#include "remote/remote_commands.h"
#include "terminal/exit_codes.h"

namespace dembuf::cli {

void AddRemoteCommands(CLI::App& app, CommandOptions&, CommandTable& commands) {
  for (const char* name :
       {"submit", "list", "status", "watch", "fetch", "cancel", "delete", "server-info", "push"}) {
    // push is `dembuf bed push`, beside export.
    CLI::App* group = std::string_view(name) == "push" ? app.get_subcommand("bed") : &app;
    CLI::App* command = group->add_subcommand(name, "(needs a build with the service)");
    command->allow_extras();      // whatever follows the name: the answer is the same
    command->fallthrough(false);  // (not handed to the program's options, which refuse it)
    command->group("");           // not listed in --help
    commands.Add(command, [name] {
      std::fprintf(stderr,
                   "dembuf: %s talks to a dembufd, and this dembuf was built without the service "
                   "(cmake -DDEMBUF_SERVICE=OFF); run and sweep work here\n",
                   name);
      return static_cast<int>(kExitBadInput);
    });
  }
}

}  // namespace dembuf::cli
