// Per-user API tokens: random, shown once when created, stored only as SHA-256 hashes.
#pragma once

#include <string>

namespace dembuf::server {

/// 32 random bytes from the system's generator, as 64 hex digits.
std::string NewToken();

/// SHA-256 of the token, hex.
std::string HashToken(const std::string& token);

/// Why `name` cannot be a user's name ("" when it can): 1 to 64 letters, digits, '.', '_'
/// and '-' (names end up in logs, tables and folder names).
std::string UserNameProblem(const std::string& name);

/// Whether `listen` (host:port) is a loopback address, where tokens are optional.
bool IsLoopback(const std::string& listen);

}  // namespace dembuf::server
