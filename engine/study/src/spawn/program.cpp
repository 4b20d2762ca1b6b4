#include "dembuf/study/spawn/program.h"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <stdexcept>

extern char** environ;

namespace dembuf {

namespace {

// The program and its process group: what it started goes too, unless it left the group, and
// the program itself even if it moved to another group.
void KillProgram(pid_t pid) {
  kill(-pid, SIGKILL);
  kill(pid, SIGKILL);
}

// Waits for the program's exit, its output ended: it may have closed its output and run on.
// Past the deadline (if `timed`) it is killed, and timed_out set. Returns its wait status.
int WaitForExit(pid_t pid, bool timed, std::chrono::steady_clock::time_point deadline,
                ProgramResult& result) {
  int status = 0;
  for (;;) {
    const bool killed = result.timed_out || result.overflowed;
    const pid_t ended = waitpid(pid, &status, timed && !killed ? WNOHANG : 0);
    if (ended == pid) return status;
    if (ended < 0 && errno == EINTR) continue;
    if (ended < 0) return SIGKILL;  // reaped elsewhere (cannot happen): not taken for a success
    if (std::chrono::steady_clock::now() >= deadline) {
      KillProgram(pid);
      result.timed_out = true;
      continue;
    }
    usleep(10000);
  }
}

}  // namespace

ProgramResult RunProgram(const std::vector<std::string>& args, std::chrono::milliseconds timeout,
                         const std::vector<std::string>& environment) {
  if (args.empty()) throw std::invalid_argument("RunProgram: no program");
  int pipe_fds[2];
  if (pipe2(pipe_fds, O_CLOEXEC) != 0)
    throw std::runtime_error("cannot make a pipe for " + args[0]);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, pipe_fds[1], STDOUT_FILENO);
  posix_spawn_file_actions_adddup2(&actions, pipe_fds[1], STDERR_FILENO);
  posix_spawn_file_actions_addopen(&actions, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
  std::vector<char*> argv;
  for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  // Its own process group, so that a kill reaches what it started too (a script's commands).
  posix_spawnattr_t attributes;
  posix_spawnattr_init(&attributes);
  posix_spawnattr_setflags(&attributes, POSIX_SPAWN_SETPGROUP);
  posix_spawnattr_setpgroup(&attributes, 0);
  pid_t pid = 0;
  // This process's environment, with `environment`'s NAME=value entries put first (the first
  // of a name is the one a program reads).
  std::vector<char*> envp;
  for (const std::string& entry : environment) envp.push_back(const_cast<char*>(entry.c_str()));
  for (char** e = environ; *e; ++e) envp.push_back(*e);
  envp.push_back(nullptr);
  const int spawned =
      posix_spawnp(&pid, args[0].c_str(), &actions, &attributes, argv.data(), envp.data());
  posix_spawn_file_actions_destroy(&actions);
  posix_spawnattr_destroy(&attributes);
  close(pipe_fds[1]);
  ProgramResult result;
  if (spawned != 0) {
    close(pipe_fds[0]);
    result.exit_code = 127;  // as a shell says of a program it cannot find
    result.output = args[0] + ": cannot run it (not installed, or not in PATH)";
    return result;
  }
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  char buf[4096];
  for (;;) {
    int wait_ms = -1;
    if (timeout.count() > 0) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
          deadline - std::chrono::steady_clock::now());
      if (left.count() <= 0) {
        KillProgram(pid);
        result.timed_out = true;
        break;
      }
      wait_ms = static_cast<int>(left.count());
    }
    pollfd fd{pipe_fds[0], POLLIN, 0};
    const int ready = poll(&fd, 1, wait_ms);
    if (ready < 0 && errno == EINTR) continue;
    if (ready == 0) continue;  // the deadline is checked above
    const ssize_t n = read(pipe_fds[0], buf, sizeof buf);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    if (result.output.size() + static_cast<std::size_t>(n) > kMaxProgramOutput) {
      KillProgram(pid);
      result.overflowed = true;
      break;
    }
    result.output.append(buf, static_cast<std::size_t>(n));
  }
  close(pipe_fds[0]);
  const int status = WaitForExit(pid, timeout.count() > 0, deadline, result);
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  return result;
}

std::string ShellQuote(std::string_view text) {
  std::string out = "'";
  for (const char c : text) {
    if (c == '\'')
      out += "'\\''";
    else
      out += c;
  }
  return out + "'";
}

}  // namespace dembuf
