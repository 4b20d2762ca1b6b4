// Per-user API tokens: random, shown once when created, stored only as SHA-256 hashes.
#pragma once

#include <optional>
#include <string>

namespace dembuf::server {

class Store;

/// Who is asking. Without a token (allowed on loopback unless tokens are required), the
/// caller is whoever the request says, with every right: the trusted single-machine mode.
struct Caller {
  std::string name;
  bool admin = false;
  bool token = false;  ///< identified by a token (not a name the request gave)
};

/// The holder of `token` (by its hash in the store), or nothing for a token not known.
std::optional<Caller> CallerOfToken(Store& store, const std::string& token);

/// Whether `caller` may see and cancel what `owner` owns: their own, or anything for an admin.
inline bool MaySee(const Caller& caller, const std::string& owner) {
  return caller.admin || caller.name == owner;
}

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
