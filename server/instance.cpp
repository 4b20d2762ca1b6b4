#include "instance.h"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <cctype>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <stdexcept>

namespace dembuf::server {

namespace fs = std::filesystem;

DatabaseLock::DatabaseLock(const std::string& db_path) : m_path(db_path + ".lock") {
  m_fd = open(m_path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (m_fd < 0)
    throw std::runtime_error("database " + db_path + " cannot be used: it cannot be written (" +
                             std::strerror(errno) + " for its lock file " + m_path + ")");
  if (flock(m_fd, LOCK_EX | LOCK_NB) != 0) {
    std::ifstream in(m_path);
    std::string holder;
    std::getline(in, holder);
    close(m_fd);
    m_fd = -1;
    throw std::runtime_error("database " + db_path + " is in use by another dembufd: " +
                             (holder.empty() ? std::string("one that is starting") : holder) +
                             "; stop it first, or give this one another --db");
  }
  Describe("process " + std::to_string(getpid()) + ", starting");
}

DatabaseLock::~DatabaseLock() {
  if (m_fd >= 0) close(m_fd);  // releases the lock; the file stays, unlocked
}

void DatabaseLock::Describe(const std::string& holder) {
  const std::string line = holder + "\n";
  if (ftruncate(m_fd, 0) == 0 && pwrite(m_fd, line.data(), line.size(), 0) >= 0) fsync(m_fd);
}

namespace {

// The first process with one of these sockets open, as "process PID (command line)".
std::string ProcessWithSocket(const std::set<std::string>& sockets) {
  std::error_code error;
  for (const auto& process : fs::directory_iterator("/proc")) {
    const std::string pid = process.path().filename().string();
    if (pid.empty() || !std::isdigit(static_cast<unsigned char>(pid[0]))) continue;
    for (const auto& fd : fs::directory_iterator(process.path() / "fd", error)) {
      if (!sockets.count(fs::read_symlink(fd.path(), error).string())) continue;
      std::ifstream cmdline(process.path() / "cmdline");
      std::string command((std::istreambuf_iterator<char>(cmdline)), {});
      for (char& c : command)
        if (c == '\0') c = ' ';
      while (!command.empty() && command.back() == ' ') command.pop_back();
      return "process " + pid + " (" + command + ")";
    }
  }
  return "";
}

}  // namespace

std::string PortHolder(int port) {
  // The inodes of the sockets listening on the port (state 0A), IPv4 and IPv6.
  std::set<std::string> sockets;
  for (const char* table : {"/proc/net/tcp", "/proc/net/tcp6"}) {
    std::ifstream in(table);
    std::string line;
    std::getline(in, line);  // the header
    while (std::getline(in, line)) {
      std::istringstream fields(line);
      std::string slot, local, remote, state, queues, timer, retransmits, uid, timeout, inode;
      fields >> slot >> local >> remote >> state >> queues >> timer >> retransmits >> uid >>
          timeout >> inode;
      const auto colon = local.rfind(':');
      if (state != "0A" || colon == std::string::npos) continue;
      if (std::stoi(local.substr(colon + 1), nullptr, 16) == port)
        sockets.insert("socket:[" + inode + "]");
    }
  }
  if (sockets.empty()) return "";
  // Processes come and go while /proc is read; whatever cannot be read is passed over.
  try {
    return ProcessWithSocket(sockets);
  } catch (const std::exception&) {
    return "";
  }
}

}  // namespace dembuf::server
