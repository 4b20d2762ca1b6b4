// The holders of API tokens (by the token's hash): a table of the store (store.h).
#pragma once

#include <string>
#include <vector>

#include "store/connection.h"
#include "store/records.h"

namespace dembuf::server {

/// Users and their tokens' hashes.
class UserTable {
 public:
  /// Users: a token's hash names its user. SetUser adds one or replaces its token.
  void SetUser(const std::string& name, const std::string& token_hash, bool admin);
  std::vector<User> ListUsers();
  bool RemoveUser(const std::string& name);
  bool AnyUsers();

 protected:
  explicit UserTable(Connection& connection) : m_connection(connection) {}

 private:
  Connection& m_connection;
};

}  // namespace dembuf::server
