// One daemon per database and per port. A second dembufd on the same database would run the
// same jobs twice; on the same port (gRPC lets sockets share a port) it would take half of
// the requests. Both are refused at start, naming the daemon that is there.
#pragma once

#include <string>
#include <utility>

#include "store/owned_files.h"

namespace dembuf::server {

/// An exclusive lock on a database for this process's life, held with flock on the database
/// file itself (the kernel drops it when the process ends, however it ends). A lock belongs to
/// the file, not to its name: a hard link to the same database meets the same lock. Beside
/// the file (its name + ".lock"), a line says who holds it.
///
/// The database is the daemon's own (owned_files.h): its folder belongs to the daemon's
/// account and no other may write it; the file and its SQLite side files (-wal, -shm,
/// -journal) are regular files of that account, never links; otherwise the lock is refused
/// with OwnershipError, naming the path, owner, mode and the fix. Another account could
/// otherwise have made the database, or an empty -wal beside it, and read every job.
class DatabaseLock {
 public:
  /// Takes the lock, creating an empty database file (0600) when there is none and `create`
  /// is set (else a missing database is an error); throws std::runtime_error naming the
  /// daemon that holds it.
  explicit DatabaseLock(const std::string& db_path, bool create = true);
  ~DatabaseLock();
  DatabaseLock(const DatabaseLock&) = delete;
  DatabaseLock& operator=(const DatabaseLock&) = delete;

  /// Records who holds it, for a second daemon's message (e.g. the address it listens on).
  void Describe(const std::string& holder);
  /// Closes the database and its side files to other accounts (0600), through the files'
  /// descriptors, never a link; returns those that were open before (for a warning), "" when
  /// none was.
  std::string MakePrivate();

 private:
  DatabaseLock(std::pair<OwnedFolder, std::string> folder, const std::string& db_path, bool create);

  OwnedFolder m_folder;  ///< the database's folder
  std::string m_name;    ///< the database's file name in it
  int m_fd = -1;         ///< the database file, locked
};

/// Checks a database's folder and files as DatabaseLock does, without taking the lock (for
/// the token commands, which work beside a running daemon). Throws OwnershipError.
void CheckDatabaseFiles(const std::string& db_path);

/// Who listens on a TCP port of this machine, e.g. "process 1234 (dembufd --db x.db)", from
/// /proc; "" when that cannot be seen (another user's process, another system).
std::string PortHolder(int port);

}  // namespace dembuf::server
