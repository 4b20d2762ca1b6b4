// Running another program: the plotter (gnuplot) for the client, Slurm's commands for the
// daemon; the study layer's, so that both programs use it. Hand-written over posix_spawn
// because the standard library has no process API, and popen or system would pass every
// argument through a shell.
#pragma once

#include <chrono>
#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

namespace dembuf {

struct ProgramResult {
  int exit_code = 0;   ///< 127: not found; 128 + N: ended by signal N (a timeout: SIGKILL)
  std::string output;  ///< stdout and stderr together, at most kMaxProgramOutput bytes
  bool timed_out = false;
  bool overflowed = false;  ///< it printed more than kMaxProgramOutput and was killed
};

/// The most a program's output may hold: a program that prints more (a cluster's command gone
/// wrong, or hostile) is killed rather than given the daemon's memory. squeue's lines for a
/// hundred thousand jobs take about 10 MB.
inline constexpr std::size_t kMaxProgramOutput = 64u << 20;

/// Runs `args[0]` (looked up in PATH) with these arguments, no shell between, and waits for it;
/// after `timeout` (0: none) it is killed and timed_out is set; one whose output passes
/// kMaxProgramOutput is killed too, and overflowed is set. The timeout holds whether or not
/// the program keeps its output open. It runs in a process group of its own, and a kill ends
/// the whole group: the programs it started go with it, unless they left the group (setsid).
/// `environment` ("NAME=value" entries) is added to this process's environment for it: unlike its
/// arguments, which every account may read in /proc, its environment only its own account may.
ProgramResult RunProgram(const std::vector<std::string>& args,
                         std::chrono::milliseconds timeout = std::chrono::milliseconds(0),
                         const std::vector<std::string>& environment = {});

/// `text` as one word for a POSIX shell: in single quotes, each quote written '\''. For the
/// one place a shell line cannot be avoided (sbatch --wrap).
std::string ShellQuote(std::string_view text);

}  // namespace dembuf
