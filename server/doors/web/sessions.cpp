#include "doors/web/sessions.h"

#include <algorithm>

#include "access/auth.h"
#include "dembuf/study/files/provenance.h"

namespace dembuf::server::web {

std::string Sessions::Open(const std::string& token_hash) {
  const std::string id = NewToken();
  const Clock::time_point now = Clock::now();
  std::lock_guard lock(m_mutex);
  std::erase_if(m_sessions, [&](const auto& entry) { return entry.second.expires <= now; });
  auto by_expiry = [](const auto& a, const auto& b) { return a.second.expires < b.second.expires; };
  // The token's own oldest first, then, when all are full, anyone's oldest. (A linear pass a
  // login: logins are rare, sessions at most `capacity`.)
  while (true) {
    auto oldest_own = m_sessions.end();
    std::size_t own = 0;
    for (auto it = m_sessions.begin(); it != m_sessions.end(); ++it)
      if (it->second.token_hash == token_hash) {
        ++own;
        if (oldest_own == m_sessions.end() || by_expiry(*it, *oldest_own)) oldest_own = it;
      }
    if (own < m_per_token) break;
    m_sessions.erase(oldest_own);
  }
  while (m_sessions.size() >= m_capacity)
    m_sessions.erase(std::min_element(m_sessions.begin(), m_sessions.end(), by_expiry));
  m_sessions[Sha256Hex(id)] = {token_hash, now + m_lifetime};
  return id;
}

std::optional<std::string> Sessions::TokenHash(const std::string& session_id) {
  std::lock_guard lock(m_mutex);
  const auto found = m_sessions.find(Sha256Hex(session_id));
  if (found == m_sessions.end()) return std::nullopt;
  if (found->second.expires <= Clock::now()) {
    m_sessions.erase(found);
    return std::nullopt;
  }
  return found->second.token_hash;
}

void Sessions::Close(const std::string& session_id) {
  std::lock_guard lock(m_mutex);
  m_sessions.erase(Sha256Hex(session_id));
}

}  // namespace dembuf::server::web
