#include "store/sqlite.h"

namespace dembuf::server {

namespace {

[[noreturn]] void Throw(int code, const std::string& message) {
  if ((code & 0xff) == SQLITE_FULL) throw StorageFull(message);
  throw SqliteError(message);
}

[[noreturn]] void Fail(sqlite3* db, const std::string& what) {
  Throw(sqlite3_errcode(db), what + ": " + sqlite3_errmsg(db));
}

}  // namespace

bool Statement::Step() {
  const int rc = sqlite3_step(m_stmt);
  if (rc == SQLITE_ROW) return true;
  if (rc == SQLITE_DONE) {
    sqlite3_reset(m_stmt);
    return false;
  }
  // Read the error before the reset, which ends the statement's part in it.
  const std::string message =
      std::string("SQL failed (") + sqlite3_sql(m_stmt) + "): " + sqlite3_errmsg(m_db);
  sqlite3_reset(m_stmt);
  Throw(rc, message);
}

std::string Statement::Text(int column) const {
  const auto* p = sqlite3_column_text(m_stmt, column);
  return p ? std::string(reinterpret_cast<const char*>(p),
                         static_cast<std::size_t>(sqlite3_column_bytes(m_stmt, column)))
           : std::string();
}

std::string Statement::Blob(int column) const {
  const void* p = sqlite3_column_blob(m_stmt, column);
  return p ? std::string(static_cast<const char*>(p),
                         static_cast<std::size_t>(sqlite3_column_bytes(m_stmt, column)))
           : std::string();
}

void Statement::BindOne(int index, std::int64_t v) {
  if (sqlite3_bind_int64(m_stmt, index, v) != SQLITE_OK) Fail(m_db, "bind");
}

void Statement::BindOne(int index, double v) {
  if (sqlite3_bind_double(m_stmt, index, v) != SQLITE_OK) Fail(m_db, "bind");
}

void Statement::BindOne(int index, std::string_view v) {
  if (sqlite3_bind_text64(m_stmt, index, v.data(), v.size(), SQLITE_TRANSIENT, SQLITE_UTF8) !=
      SQLITE_OK)
    Fail(m_db, "bind");
}

void Statement::BindOne(int index, std::nullopt_t) {
  if (sqlite3_bind_null(m_stmt, index) != SQLITE_OK) Fail(m_db, "bind");
}

void Statement::BindOne(int index, Bytes v) {
  if (sqlite3_bind_blob64(m_stmt, index, v.data.data(), v.data.size(), SQLITE_TRANSIENT) !=
      SQLITE_OK)
    Fail(m_db, "bind");
}

Database::Database(const std::string& path, bool read_only) {
  const int flags =
      (read_only ? SQLITE_OPEN_READONLY : SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE) |
      SQLITE_OPEN_FULLMUTEX | SQLITE_OPEN_NOFOLLOW;
  const int rc = sqlite3_open_v2(path.c_str(), &m_db, flags, nullptr);
  if (rc != SQLITE_OK) {
    const std::string message = m_db ? sqlite3_errmsg(m_db) : sqlite3_errstr(rc);
    sqlite3_close(m_db);
    throw SqliteError("cannot open database " + path + ": " + message);
  }
  // Writers wait for each other instead of failing at once.
  sqlite3_busy_timeout(m_db, 10000);
}

Database::~Database() {
  m_statements.clear();  // finalize before closing
  sqlite3_close(m_db);
}

Statement& Database::Prepare(const std::string& sql) {
  auto it = m_statements.find(sql);
  if (it != m_statements.end()) return *it->second;
  sqlite3_stmt* stmt = nullptr;
  if (sqlite3_prepare_v3(m_db, sql.c_str(), -1, SQLITE_PREPARE_PERSISTENT, &stmt, nullptr) !=
      SQLITE_OK)
    Fail(m_db, "cannot prepare SQL (" + sql + ")");
  auto owned = std::unique_ptr<Statement>(new Statement(m_db, stmt));
  return *m_statements.emplace(sql, std::move(owned)).first->second;
}

void Database::Execute(const std::string& sql) {
  char* error = nullptr;
  const int rc = sqlite3_exec(m_db, sql.c_str(), nullptr, nullptr, &error);
  if (rc != SQLITE_OK) {
    const std::string message =
        "SQL failed (" + sql.substr(0, 60) + "): " + (error ? error : "unknown error");
    sqlite3_free(error);
    Throw(rc, message);
  }
}

}  // namespace dembuf::server
