// Browser sessions of the web pages. Logging in with a token gives a random session id, sent
// back in an HttpOnly cookie, so that the token itself is not kept by the browser. A session
// holds the token's hash, not a user: every request looks the user up again, so a revoked
// token ends its sessions at once. Sessions live in memory (a restart logs everyone out) for
// at most `lifetime`. A token holds at most `per_token` of them (its own oldest goes first), so
// that one user logging in again and again cannot push everyone else out of the `capacity`
// of all (where the oldest goes first).
#pragma once

#include <chrono>
#include <cstddef>
#include <map>
#include <mutex>
#include <optional>
#include <string>

namespace dembuf::server::web {

class Sessions {
 public:
  using Clock = std::chrono::steady_clock;

  explicit Sessions(std::chrono::seconds lifetime = std::chrono::hours(12),
                    std::size_t capacity = 10000, std::size_t per_token = 16)
      : m_lifetime(lifetime), m_capacity(capacity), m_per_token(per_token) {}

  /// A new session for the holder of the token with this hash; returns its id.
  std::string Open(const std::string& token_hash);
  /// The token hash of a live session, or nothing (unknown or expired).
  std::optional<std::string> TokenHash(const std::string& session_id);
  void Close(const std::string& session_id);

  std::chrono::seconds lifetime() const { return m_lifetime; }

 private:
  struct Session {
    std::string token_hash;
    Clock::time_point expires;
  };

  const std::chrono::seconds m_lifetime;
  const std::size_t m_capacity;
  const std::size_t m_per_token;
  std::mutex m_mutex;
  /// By the SHA-256 of the session id: the ids themselves are not kept.
  std::map<std::string, Session> m_sessions;
};

}  // namespace dembuf::server::web
