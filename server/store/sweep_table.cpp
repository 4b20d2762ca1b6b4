#include "store/sweep_table.h"

#include <nlohmann/json.hpp>

#include "dembuf/study/files/provenance.h"
#include "store/job_table.h"
#include "store/notification_table.h"

namespace dembuf::server {

namespace {

nlohmann::json AxesToJson(const std::vector<SweepAxis>& axes) {
  nlohmann::json out = nlohmann::json::array();
  for (const SweepAxis& a : axes) out.push_back({{"field", a.field}, {"values", a.values}});
  return out;
}

std::vector<SweepAxis> AxesFromJson(const std::string& text) {
  std::vector<SweepAxis> axes;
  for (const auto& a : nlohmann::json::parse(text))
    axes.push_back({a["field"].get<std::string>(), a["values"].get<std::vector<std::string>>()});
  return axes;
}

}  // namespace

void SweepTable::AddSweep(SweepRecord& sweep, std::vector<JobRecord>& jobs,
                          const std::string& request_id) {
  Connection::Writing db = m_connection.Write();
  RequireReusedResults(*db, jobs);
  sweep.created_at = report::UtcNow();
  db->Prepare("INSERT INTO sweeps (owner, name, axes_json, created_at) VALUES (?, ?, ?, ?)")
      .Bind(sweep.owner, sweep.name, AxesToJson(sweep.axes).dump(), sweep.created_at)
      .Run();
  sweep.id = db->LastInsertId();
  for (JobRecord& job : jobs) {
    job.sweep_id = sweep.id;
    InsertJob(*db, job);
  }
  if (sweep.notify) WantNotification(*db, 0, sweep.id, sweep.owner);
  RecordSubmission(*db, sweep.owner, request_id, {0, sweep.id}, sweep.created_at);
  db.Commit();
}

std::optional<SweepRecord> SweepTable::GetSweep(std::int64_t id) {
  Connection::Reading db = m_connection.Read();
  Statement& s =
      db->Prepare("SELECT id, owner, name, axes_json, created_at FROM sweeps WHERE id = ?");
  s.Bind(id);
  if (!s.Step()) return std::nullopt;
  SweepRecord sweep{s.Int(0), s.Text(1), s.Text(2), AxesFromJson(s.Text(3)), s.Text(4)};
  s.Run();
  return sweep;
}

std::vector<SweepRecord> SweepTable::ListSweeps(const std::string& owner, int limit) {
  Connection::Reading db = m_connection.Read();
  Statement& s = db->Prepare(
      "SELECT id, owner, name, axes_json, created_at FROM sweeps WHERE (? = '' OR owner = ?) "
      "ORDER BY id DESC LIMIT ?");
  s.Bind(owner, owner, limit);
  std::vector<SweepRecord> sweeps;
  while (s.Step())
    sweeps.push_back({s.Int(0), s.Text(1), s.Text(2), AxesFromJson(s.Text(3)), s.Text(4)});
  return sweeps;
}

std::map<std::string, int> SweepTable::SweepStateCounts(std::int64_t sweep_id) {
  Connection::Reading db = m_connection.Read();
  Statement& s = db->Prepare("SELECT state, count(*) FROM jobs WHERE sweep_id = ? GROUP BY state");
  s.Bind(sweep_id);
  std::map<std::string, int> counts;
  while (s.Step()) counts[s.Text(0)] = static_cast<int>(s.Int(1));
  return counts;
}

int SweepTable::SweepBedsPrepared(std::int64_t sweep_id) {
  Connection::Reading db = m_connection.Read();
  Statement& s = db->Prepare(
      "SELECT count(*) FROM bed_preparations WHERE job_id IN "
      "(SELECT id FROM jobs WHERE sweep_id = ?)");
  s.Bind(sweep_id);
  const int count = s.Step() ? static_cast<int>(s.Int(0)) : 0;
  s.Run();
  return count;
}

}  // namespace dembuf::server
