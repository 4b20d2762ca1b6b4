#include "store/user_table.h"

#include "dembuf/study/files/provenance.h"

namespace dembuf::server {

void UserTable::SetUser(const std::string& name, const std::string& token_hash, bool admin) {
  Connection::Writing db = m_connection.Write();
  db->Prepare(
        "INSERT INTO users (name, token_hash, admin, created_at) VALUES (?, ?, ?, ?) "
        "ON CONFLICT(name) DO UPDATE SET token_hash = excluded.token_hash, "
        "admin = excluded.admin")
      .Bind(name, token_hash, admin ? 1 : 0, report::UtcNow())
      .Run();
  db.Commit();
}

std::vector<User> UserTable::ListUsers() {
  Connection::Reading db = m_connection.Read();
  Statement& s = db->Prepare("SELECT name, admin, token_hash FROM users ORDER BY name");
  s.Bind();
  std::vector<User> users;
  while (s.Step()) users.push_back({s.Text(0), s.Int(1) != 0, s.Text(2)});
  return users;
}

bool UserTable::RemoveUser(const std::string& name) {
  Connection::Writing db = m_connection.Write();
  db->Prepare("DELETE FROM users WHERE name = ?").Bind(name).Run();
  const bool removed = db->Changes() > 0;
  db.Commit();
  return removed;
}

bool UserTable::AnyUsers() {
  Connection::Reading db = m_connection.Read();
  Statement& s = db->Prepare("SELECT count(*) FROM users");
  s.Bind();
  const bool any = s.Step() && s.Int(0) > 0;
  s.Run();
  return any;
}

}  // namespace dembuf::server
