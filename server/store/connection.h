// The daemon's one connection to its database, shared by the store's tables (store.h). One
// thread at a time uses it: a table reads through Read and changes through Write, one
// transaction that is rolled back unless committed, so that no table takes the lock or opens
// a transaction by hand. (The one exception is the Store's constructor: its migrations run in
// transactions of their own under Read(), beside pragmas that a transaction may not hold.)
#pragma once

#include <memory>
#include <mutex>
#include <string>

#include "store/records.h"
#include "store/sqlite.h"

namespace dembuf::server {

class Connection {
 public:
  /// The database, this thread's while the Reading lives.
  class Reading {
   public:
    Database* operator->() const { return &m_db; }
    Database& operator*() const { return m_db; }

   private:
    friend class Connection;
    Reading(std::mutex& mutex, Database& db) : m_lock(mutex), m_db(db) {}
    std::unique_lock<std::mutex> m_lock;
    Database& m_db;
  };
  /// The database in one transaction (BEGIN IMMEDIATE), rolled back unless Commit is called.
  class Writing : public Reading {
   public:
    void Commit() { m_transaction.Commit(); }

   private:
    friend class Connection;
    Writing(std::mutex& mutex, Database& db) : Reading(mutex, db), m_transaction(db) {}
    Transaction m_transaction;
  };

  /// Opens the file (read only with options.read_only); the schema is the store's.
  Connection(const std::string& path, const StoreOptions& options);

  Reading Read() { return Reading(m_mutex, *m_db); }
  Writing Write() { return Writing(m_mutex, *m_db); }
  const StoreOptions& options() const { return m_options; }

 private:
  StoreOptions m_options;
  std::mutex m_mutex;
  std::unique_ptr<Database> m_db;
};

}  // namespace dembuf::server
