// Places for long-lived streams (a gRPC watch, a web page's event stream). Each holds one of
// its server's threads while it lasts, so a user may hold only a few and all together only
// so many: the rest of the pool stays free for other requests.
#pragma once

#include <map>
#include <mutex>
#include <optional>
#include <string>

#include "access/auth.h"

namespace dembuf::server {

class StreamLimits {
 public:
  /// `what` names the streams and the settings in refusals ("watch streams",
  /// "max_watch_streams").
  StreamLimits(int per_user, int total, std::string what, std::string total_setting)
      : m_per_user(per_user),
        m_total(total),
        m_what(std::move(what)),
        m_total_setting(std::move(total_setting)) {}

  /// A place held until destroyed.
  class Place {
   public:
    Place(StreamLimits& limits, std::string user) : m_limits(&limits), m_user(std::move(user)) {}
    Place(Place&& other) noexcept : m_limits(other.m_limits), m_user(std::move(other.m_user)) {
      other.m_limits = nullptr;
    }
    Place(const Place&) = delete;
    Place& operator=(const Place&) = delete;
    Place& operator=(Place&&) = delete;
    ~Place() {
      if (m_limits) m_limits->GiveBack(m_user);
    }

   private:
    StreamLimits* m_limits;
    std::string m_user;
  };

  /// A place for a stream of `caller`, or nothing when a cap is reached (`why` says which).
  /// Without a token there is no user to count per user: only the total counts.
  std::optional<Place> Take(const Caller& caller, std::string* why) {
    std::lock_guard lock(m_mutex);
    int& mine = m_open[caller.name];
    if (caller.token && mine >= m_per_user) {
      *why = caller.name + " has " + std::to_string(mine) + " " + m_what + " open; at most " +
             std::to_string(m_per_user) + " per user";
    } else if (m_open_total >= m_total) {
      *why = "the server has " + std::to_string(m_open_total) + " " + m_what + " open; at most " +
             std::to_string(m_total) + " (" + m_total_setting + ")";
    } else {
      ++mine;
      ++m_open_total;
      return Place(*this, caller.name);
    }
    if (mine == 0) m_open.erase(caller.name);
    return std::nullopt;
  }

  int open() const {
    std::lock_guard lock(m_mutex);
    return m_open_total;
  }

 private:
  void GiveBack(const std::string& user) {
    std::lock_guard lock(m_mutex);
    if (--m_open[user] <= 0) m_open.erase(user);
    --m_open_total;
  }

  const int m_per_user;
  const int m_total;
  const std::string m_what;
  const std::string m_total_setting;
  mutable std::mutex m_mutex;
  std::map<std::string, int> m_open;  ///< open streams by user
  int m_open_total = 0;
};

}  // namespace dembuf::server
