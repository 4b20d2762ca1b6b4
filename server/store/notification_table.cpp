#include "store/notification_table.h"

#include "dembuf/study/files/provenance.h"

namespace dembuf::server {

void WantNotification(Database& db, std::int64_t job_id, std::int64_t sweep_id,
                      const std::string& owner) {
  db.Prepare(
        "INSERT INTO notifications (job_id, sweep_id, owner, state, created_at) "
        "VALUES (?, ?, ?, 'waiting', ?)")
      .Bind(job_id, sweep_id, owner, report::UtcNow())
      .Run();
}

std::vector<NotificationRecord> NotificationTable::DueNotifications(int limit) {
  Connection::Reading db = m_connection.Read();
  // A job has ended in one of the final states; a sweep when none of its jobs is left to end
  // (and it is still there: a deleted sweep is owed nothing).
  Statement& s = db->Prepare(
      "SELECT n.id, n.job_id, n.sweep_id, n.owner FROM notifications n WHERE n.state = "
      "'waiting' AND ((n.job_id != 0 AND (SELECT state FROM jobs WHERE id = n.job_id) IN "
      "('done', 'failed', 'cancelled')) OR (n.sweep_id != 0 AND EXISTS (SELECT 1 FROM sweeps "
      "WHERE id = n.sweep_id) AND NOT EXISTS (SELECT 1 FROM jobs WHERE sweep_id = n.sweep_id "
      "AND state NOT IN ('done', 'failed', 'cancelled')))) ORDER BY n.id LIMIT ?");
  s.Bind(limit);
  std::vector<NotificationRecord> due;
  while (s.Step()) due.push_back({s.Int(0), s.Int(1), s.Int(2), s.Text(3)});
  return due;
}

int NotificationTable::CountWaitingNotifications(const std::string& owner) {
  Connection::Reading db = m_connection.Read();
  // Those still waiting, and those of the last hour (a job cancelled at once would be told of
  // at once: a flood of them is bounded too).
  Statement& s = db->Prepare(
      "SELECT count(*) FROM notifications WHERE owner = ? AND (state = 'waiting' OR created_at "
      ">= strftime('%Y-%m-%dT%H:%M:%SZ', 'now', '-1 hour'))");
  s.Bind(owner);
  const int count = s.Step() ? static_cast<int>(s.Int(0)) : 0;
  s.Run();
  return count;
}

void NotificationTable::EndNotification(std::int64_t id, const std::string& state,
                                        const std::string& error) {
  Connection::Writing db = m_connection.Write();
  db->Prepare("UPDATE notifications SET state = ?, error = ?, ended_at = ? WHERE id = ?")
      .Bind(state, error, report::UtcNow(), id)
      .Run();
  db.Commit();
}

}  // namespace dembuf::server
