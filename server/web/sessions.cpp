#include "sessions.h"

#include <algorithm>

#include "auth.h"
#include "dembuf/study/provenance.h"

namespace dembuf::server::web {

std::string Sessions::Open(const std::string& token_hash) {
  const std::string id = NewToken();
  const Clock::time_point now = Clock::now();
  std::lock_guard lock(m_mutex);
  std::erase_if(m_sessions, [&](const auto& entry) { return entry.second.expires <= now; });
  while (m_sessions.size() >= m_capacity) {
    const auto oldest = std::min_element(
        m_sessions.begin(), m_sessions.end(),
        [](const auto& a, const auto& b) { return a.second.expires < b.second.expires; });
    m_sessions.erase(oldest);
  }
  m_sessions[report::Sha256Hex(id)] = {token_hash, now + m_lifetime};
  return id;
}

std::optional<std::string> Sessions::TokenHash(const std::string& session_id) {
  std::lock_guard lock(m_mutex);
  const auto found = m_sessions.find(report::Sha256Hex(session_id));
  if (found == m_sessions.end()) return std::nullopt;
  if (found->second.expires <= Clock::now()) {
    m_sessions.erase(found);
    return std::nullopt;
  }
  return found->second.token_hash;
}

void Sessions::Close(const std::string& session_id) {
  std::lock_guard lock(m_mutex);
  m_sessions.erase(report::Sha256Hex(session_id));
}

}  // namespace dembuf::server::web
