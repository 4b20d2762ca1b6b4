// A thin RAII layer over the SQLite C API: a connection, cached prepared statements with typed
// binding, and transactions that roll back unless committed.
#pragma once

#include <sqlite3.h>

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace dembuf::server {

/// An SQLite failure, with SQLite's message.
class SqliteError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// The disk holding the database is full: nothing was written, and the same write can succeed
/// once space is freed.
class StorageFull : public SqliteError {
 public:
  using SqliteError::SqliteError;
};

class Statement {
 public:
  /// Binary data, bound as a BLOB.
  struct Bytes {
    std::string_view data;
  };

  Statement(sqlite3* db, sqlite3_stmt* stmt) : m_db(db), m_stmt(stmt) {}
  ~Statement() { sqlite3_finalize(m_stmt); }
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;

  /// Binds parameters 1, 2, ... in order, replacing earlier bindings.
  template <class... Args>
  Statement& Bind(const Args&... args) {
    sqlite3_reset(m_stmt);
    sqlite3_clear_bindings(m_stmt);
    int index = 0;
    (BindOne(++index, args), ...);
    return *this;
  }

  /// Advances to the next row; false when there is none.
  bool Step();
  /// Runs a statement that returns no rows.
  void Run() {
    while (Step()) {
    }
  }
  /// Ends a statement stepped part way, its other rows left unread.
  void Reset() { sqlite3_reset(m_stmt); }

  std::int64_t Int(int column) const { return sqlite3_column_int64(m_stmt, column); }
  std::string Text(int column) const;
  std::string Blob(int column) const;
  /// A REAL column; nullopt where it is NULL.
  std::optional<double> Real(int column) const {
    if (sqlite3_column_type(m_stmt, column) == SQLITE_NULL) return std::nullopt;
    return sqlite3_column_double(m_stmt, column);
  }

 private:
  void BindOne(int index, std::int64_t v);
  void BindOne(int index, int v) { BindOne(index, static_cast<std::int64_t>(v)); }
  void BindOne(int index, double v);
  void BindOne(int index, std::string_view v);
  void BindOne(int index, const std::string& v) { BindOne(index, std::string_view(v)); }
  void BindOne(int index, const char* v) { BindOne(index, std::string_view(v)); }
  void BindOne(int index, std::nullopt_t);
  template <class T>
  void BindOne(int index, const std::optional<T>& v) {
    if (v)
      BindOne(index, *v);
    else
      BindOne(index, std::nullopt);
  }
  void BindOne(int index, Bytes v);
  friend class Database;

  sqlite3* m_db;
  sqlite3_stmt* m_stmt;
};

class Database {
 public:
  /// Opens (creating if absent) the database file; `read_only`: opens it for reading, and
  /// never creates or changes it. Throws SqliteError.
  explicit Database(const std::string& path, bool read_only = false);
  ~Database();
  Database(const Database&) = delete;
  Database& operator=(const Database&) = delete;

  /// The prepared statement for this SQL, compiled once and reused.
  Statement& Prepare(const std::string& sql);
  /// Runs one or more statements without results.
  void Execute(const std::string& sql);
  std::int64_t LastInsertId() const { return sqlite3_last_insert_rowid(m_db); }
  /// Whether the database was opened read-only (SQLite falls back to it silently).
  bool ReadOnly() const { return sqlite3_db_readonly(m_db, "main") == 1; }
  /// The longest string or blob this connection accepts.
  void SetLengthLimit(int bytes) { sqlite3_limit(m_db, SQLITE_LIMIT_LENGTH, bytes); }
  int Changes() const { return sqlite3_changes(m_db); }

  static Statement::Bytes AsBlob(std::string_view data) { return {data}; }

 private:
  sqlite3* m_db = nullptr;
  std::map<std::string, std::unique_ptr<Statement>> m_statements;
};

/// BEGIN IMMEDIATE on construction; ROLLBACK on destruction unless Commit() was called.
class Transaction {
 public:
  explicit Transaction(Database& db) : m_db(db) { m_db.Execute("BEGIN IMMEDIATE"); }
  ~Transaction() {
    if (!m_done) {
      try {
        m_db.Execute("ROLLBACK");
      } catch (const SqliteError&) {
        // nothing more can be done; the connection reports it on its next use
      }
    }
  }
  void Commit() {
    m_db.Execute("COMMIT");
    m_done = true;
  }

 private:
  Database& m_db;
  bool m_done = false;
};

}  // namespace dembuf::server
