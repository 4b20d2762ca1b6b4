// The exit codes of dembuf, for every command, local or remote (README.md lists them too).
#pragma once

namespace dembuf::cli {

enum ExitCode : int {
  kExitDone = 0,
  kExitRuntime = 1,    ///< a runtime failure: files, the server, the network
  kExitBadInput = 2,   ///< a bad scene, request or argument
  kExitFailed = 3,     ///< a run became unstable, or a remote job failed
  kExitCancelled = 4,  ///< a remote job was cancelled (status, watch and fetch alike)
  // 128 + N: interrupted by signal N (130 for SIGINT, 143 for SIGTERM), as a shell reports it
};

inline constexpr const char* kExitCodesHelp =
    "Exit codes: 0 done; 1 a runtime failure (files, the server); 2 bad input (a scene, a "
    "request, the arguments); 3 a run became unstable or a remote job failed; 4 a remote job was "
    "cancelled; 130 and 143 interrupted by SIGINT (Ctrl-C) and SIGTERM.";

}  // namespace dembuf::cli
