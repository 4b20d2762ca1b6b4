#include "process/instance.h"

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
#include <utility>
#include <vector>

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

// The SQLite files beside a database: its journal in WAL mode, the shared memory index, and the
// rollback journal.
constexpr const char* kSideFiles[] = {"-wal", "-shm", "-journal"};

// The database's folder, checked, with the database's name in it; its side files checked too
// (each must be the daemon's regular file, or absent).
std::pair<OwnedFolder, std::string> DatabaseFolder(const std::string& db_path) {
  const fs::path path = fs::absolute(db_path);
  if (!IsPlainName(path.filename().string()))
    throw OwnershipError("database " + db_path + ": not a file name");
  OwnedFolder folder = OwnedFolder::Open(path.parent_path(), "the database folder", false);
  std::string name = path.filename().string();
  for (const char* suffix : kSideFiles) folder.CheckOwned(name + suffix);
  return {std::move(folder), std::move(name)};
}

}  // namespace

void CheckDatabaseFiles(const std::string& db_path) {
  auto [folder, name] = DatabaseFolder(db_path);
  folder.CheckOwned(name);
}

DatabaseLock::DatabaseLock(const std::string& db_path, bool create)
    : DatabaseLock(DatabaseFolder(db_path), db_path, create) {}

DatabaseLock::DatabaseLock(std::pair<OwnedFolder, std::string> folder, const std::string& db_path,
                           bool create)
    : m_folder(std::move(folder.first)), m_name(std::move(folder.second)) {
  if (!create && !m_folder.Contains(m_name))
    throw std::runtime_error("database " + db_path + " does not exist");
  try {
    // A database only checked (create unset) may be read-only; flock needs no write access.
    m_fd = create ? m_folder.OpenToUpdate(m_name) : m_folder.OpenToRead(m_name);
  } catch (const OwnershipError& e) {
    if (e.system_error() == EROFS || e.system_error() == EACCES)
      throw std::runtime_error("database " + db_path + " cannot be used: it cannot be written (" +
                               std::strerror(e.system_error()) + ")");
    throw;
  }
  if (flock(m_fd, LOCK_EX | LOCK_NB) != 0) {
    std::string holder;
    try {
      const std::string note = m_folder.Read(m_name + ".lock", 4096).value_or("");
      holder = note.substr(0, note.find('\n'));
    } catch (const std::exception&) {
      // an unreadable note names nobody
    }
    struct stat file {};
    if (fstat(m_fd, &file) == 0 && holder.empty()) holder = FlockHolder(file.st_dev, file.st_ino);
    close(m_fd);
    m_fd = -1;
    throw std::runtime_error("database " + db_path + " is in use by another dembufd: " +
                             (holder.empty() ? std::string("one that is starting") : holder) +
                             "; stop it first, or give this one another --db");
  }
}

DatabaseLock::~DatabaseLock() {
  if (m_fd >= 0) close(m_fd);  // releases the lock
}

void DatabaseLock::Describe(const std::string& holder) {
  // Written whole and renamed into place: a second daemon reads either line, never half.
  try {
    m_folder.Write(m_name + ".lock", holder + "\n");
  } catch (const std::exception&) {
    // the note only helps a second daemon's message
  }
}

std::string DatabaseLock::MakePrivate() {
  std::string opened;
  std::vector<std::string> names = {m_name, m_name + ".lock"};
  for (const char* suffix : kSideFiles) names.push_back(m_name + suffix);
  for (const std::string& name : names) {
    if (!m_folder.Contains(name)) continue;
    const int fd = name == m_name ? m_fd : m_folder.OpenToRead(name);
    struct stat file {};
    if (fstat(fd, &file) == 0 && (file.st_mode & 077) != 0 && fchmod(fd, 0600) == 0)
      opened += (opened.empty() ? "" : ", ") + (m_folder.path() / name).string();
    if (fd != m_fd) close(fd);
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
