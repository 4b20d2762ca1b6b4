// One daemon per database and per port. A second dembufd on the same database would run the
// same jobs twice; on the same port (gRPC lets sockets share a port) it would take half of
// the requests. Both are refused at start, naming the daemon that is there.
#pragma once

#include <string>

namespace dembuf::server {

/// An exclusive lock on a database for this process's life, held with flock on the database
/// file itself (the kernel drops it when the process ends, however it ends). A lock belongs to
/// the file, not to its name: a symlink or a hard link to the same database meets the same
/// lock. Beside the file (its resolved path + ".lock"), a line says who holds it.
class DatabaseLock {
 public:
  /// Takes the lock, creating an empty database file (0600) when there is none; throws
  /// std::runtime_error naming the daemon that holds it.
  explicit DatabaseLock(const std::string& db_path);
  ~DatabaseLock();
  DatabaseLock(const DatabaseLock&) = delete;
  DatabaseLock& operator=(const DatabaseLock&) = delete;

  /// Records who holds it, for a second daemon's message (e.g. the address it listens on).
  void Describe(const std::string& holder);

 private:
  std::string m_note_path;  ///< the line saying who holds the lock
  int m_fd = -1;            ///< the database file, locked
};

/// Makes the database and its SQLite side files (-wal, -shm, -journal) readable by their owner
/// only, as the daemon's umask (0077) makes every file it creates; returns the files that were
/// open to others before (for a warning), "" when none.
std::string MakeDatabasePrivate(const std::string& db_path);

/// Who listens on a TCP port of this machine, e.g. "process 1234 (dembufd --db x.db)", from
/// /proc; "" when that cannot be seen (another user's process, another system).
std::string PortHolder(int port);

}  // namespace dembuf::server
