// The notifications the daemon owes its users: a job or sweep submitted with `notify` is told
// to the administrator's chat hook (server/notify/) once it has ended. Kept in the database,
// filed with the job or sweep in one transaction, so that none is lost to a restart: a
// daemon sends the ones its predecessor did not. A table of the store (store.h).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "store/connection.h"

namespace dembuf::server {

/// The notifications one user may be owed at once, and be filed in an hour: a message a job is
/// a flood in a chat; a sweep is told of once, however many its jobs.
inline constexpr int kMaxWaitingNotificationsPerUser = 100;

/// One notification owed: for a job of its own (`job_id`) or for a sweep (`sweep_id`).
struct NotificationRecord {
  std::int64_t id = 0;
  std::int64_t job_id = 0;    ///< 0 for a sweep's
  std::int64_t sweep_id = 0;  ///< 0 for a job's
  std::string owner;
};

/// Files (in the caller's transaction) a notification owed when the job (sweep_id 0) or the
/// sweep (job_id 0) ends.
void WantNotification(Database& db, std::int64_t job_id, std::int64_t sweep_id,
                      const std::string& owner);

class NotificationTable {
 public:
  /// The notifications whose job, or every job of whose sweep, has ended; oldest first, at
  /// most `limit`.
  std::vector<NotificationRecord> DueNotifications(int limit = 100);
  /// The notifications `owner` is owed that still wait for their job or sweep to end, and
  /// those filed in the last hour.
  int CountWaitingNotifications(const std::string& owner);
  /// Marks a notification sent ("sent") or given up ("failed", with why).
  void EndNotification(std::int64_t id, const std::string& state, const std::string& error = "");

 protected:
  explicit NotificationTable(Connection& connection) : m_connection(connection) {}

 private:
  Connection& m_connection;
};

}  // namespace dembuf::server
