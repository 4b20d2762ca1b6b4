// The threads that do the work of the daemon's unary calls, taking their users in turn. gRPC's
// callback threads only identify a caller (from memory: AccessPolicy) and hand the call over,
// so a flood of calls without a token costs each a look at a header and takes no thread, and
// one user's flood waits behind itself: each user has a bounded queue, a free thread takes the
// next call of the user whose turn it is, not the oldest call of all, and no user has more
// than a few calls running at once (heavy calls of one user leave the other threads free).
#pragma once

#include <condition_variable>
#include <cstddef>
#include <deque>
#include <functional>
#include <map>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace dembuf::server {

class CallPool {
 public:
  /// `threads` workers; at most `max_running_per_user` calls of one user run at once, and
  /// `max_waiting_per_user` wait.
  CallPool(int threads, std::size_t max_running_per_user, std::size_t max_waiting_per_user);
  /// Runs the calls still waiting, then stops the workers.
  ~CallPool();
  CallPool(const CallPool&) = delete;
  CallPool& operator=(const CallPool&) = delete;

  /// Queues `work` for `user`; false (and nothing queued) when the user has
  /// max_waiting_per_user calls waiting already.
  bool Queue(const std::string& user, std::function<void()> work);

  std::size_t max_waiting_per_user() const { return m_max_waiting; }

 private:
  void Work();

  const std::size_t m_max_running;
  const std::size_t m_max_waiting;
  std::mutex m_mutex;
  std::condition_variable m_changed;
  std::map<std::string, std::deque<std::function<void()>>> m_waiting;  ///< by user
  std::map<std::string, std::size_t> m_running;                        ///< by user
  /// The users with calls waiting, in the order their turns come.
  std::deque<std::string> m_turns;
  bool m_stopping = false;
  std::vector<std::thread> m_workers;
};

}  // namespace dembuf::server
