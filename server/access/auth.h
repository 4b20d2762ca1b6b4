// Per-user API tokens: random, shown once when created, stored only as SHA-256 hashes.
#pragma once

#include <optional>
#include <string>

namespace dembuf::server {

/// Who is asking: a token's holder, or the machine's trusted user where the daemon's access
/// policy allows requests without a token (access_policy.h).
struct Caller {
  std::string name;
  bool admin = false;
  bool token = false;      ///< identified by a token (not a name the request gave)
  std::string token_hash;  ///< its token's hash: a long-lived stream checks it still holds
};

/// 32 random bytes from the system's generator, as 64 hex digits.
std::string NewToken();

/// SHA-256 of the token, hex.
std::string HashToken(const std::string& token);

/// Why `name` cannot be a user's name ("" when it can): 1 to 64 letters, digits, '.', '_'
/// and '-' (names end up in logs, tables and folder names).
std::string UserNameProblem(const std::string& name);

/// Whether `listen` (host:port, or unix:PATH) reaches only this machine.
bool IsLoopback(const std::string& listen);

}  // namespace dembuf::server
