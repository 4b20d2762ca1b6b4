#include "instance.h"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <unistd.h>

#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <stdexcept>

namespace dembuf::server {

namespace fs = std::filesystem;

namespace {

// The process holding a flock on the file of this device and inode, from /proc/locks ("" when
// none is seen): for a second name of the database whose ".lock" line is elsewhere.
std::string FlockHolder(dev_t device, ino_t inode) {
  std::ifstream locks("/proc/locks");
  std::string line;
  char wanted[64];
  std::snprintf(wanted, sizeof wanted, "%02x:%02x:%lu", major(device), minor(device),
                static_cast<unsigned long>(inode));
  while (std::getline(locks, line)) {
    std::istringstream fields(line);
    std::string number, kind, mode, access, pid, file;
    fields >> number >> kind >> mode >> access >> pid >> file;
    if (kind == "FLOCK" && file == wanted) return "process " + pid;
  }
  return "";
}

}  // namespace

DatabaseLock::DatabaseLock(const std::string& db_path) {
  m_fd = open(db_path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0600);
  if (m_fd < 0)
    throw std::runtime_error("database " + db_path + " cannot be used: it cannot be written (" +
                             std::strerror(errno) + ")");
  std::error_code error;
  const fs::path resolved = fs::canonical(db_path, error);
  m_note_path = (error ? fs::path(db_path) : resolved).string() + ".lock";
  if (flock(m_fd, LOCK_EX | LOCK_NB) != 0) {
    std::ifstream in(m_note_path);
    std::string holder;
    std::getline(in, holder);
    struct stat file {};
    if (fstat(m_fd, &file) == 0 && holder.empty()) holder = FlockHolder(file.st_dev, file.st_ino);
    close(m_fd);
    m_fd = -1;
    throw std::runtime_error("database " + db_path + " is in use by another dembufd: " +
                             (holder.empty() ? std::string("one that is starting") : holder) +
                             "; stop it first, or give this one another --db");
  }
  Describe("process " + std::to_string(getpid()) + ", starting");
}

DatabaseLock::~DatabaseLock() {
  if (m_fd >= 0) close(m_fd);  // releases the lock
}

void DatabaseLock::Describe(const std::string& holder) {
  // Written whole and renamed into place: a second daemon reads either line, never half.
  const std::string temporary = m_note_path + ".new";
  std::ofstream out(temporary, std::ios::trunc);
  out << holder << "\n";
  out.close();
  std::error_code error;
  if (out) fs::rename(temporary, m_note_path, error);
}

std::string MakeDatabasePrivate(const std::string& db_path) {
  std::string opened;
  for (const char* suffix : {"", "-wal", "-shm", "-journal", ".lock"}) {
    const std::string path = db_path + suffix;
    struct stat file {};
    if (stat(path.c_str(), &file) != 0 || (file.st_mode & 077) == 0) continue;
    if (chmod(path.c_str(), file.st_mode & 0700) == 0)
      opened += (opened.empty() ? "" : ", ") + path;
  }
  return opened;
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
