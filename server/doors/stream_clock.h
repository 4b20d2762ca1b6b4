// One thread that runs the daemon's streams' timed work: a watch stream's next look at its
// job, a write's deadline. A stream waiting for its job holds an entry here, not a thread, so
// a thousand idle streams cost a thousand small entries.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <mutex>
#include <queue>
#include <thread>
#include <vector>

namespace dembuf::server {

class StreamClock {
 public:
  using Clock = std::chrono::steady_clock;

  StreamClock();
  /// Stops the thread; tasks not yet due are dropped without running.
  ~StreamClock();
  StreamClock(const StreamClock&) = delete;
  StreamClock& operator=(const StreamClock&) = delete;

  /// Runs `task` on the clock's thread at `when` (at once when it has passed), in time order.
  /// A task must be short: every stream's next step waits for it.
  void At(Clock::time_point when, std::function<void()> task);

 private:
  struct Entry {
    Clock::time_point when;
    std::uint64_t order;  ///< ties run in the order they were given
    std::function<void()> task;
    bool operator>(const Entry& other) const {
      return when != other.when ? when > other.when : order > other.order;
    }
  };
  void Run();

  std::mutex m_mutex;
  std::condition_variable m_wake;
  std::priority_queue<Entry, std::vector<Entry>, std::greater<Entry>> m_entries;
  std::uint64_t m_next_order = 0;
  bool m_stopping = false;
  std::thread m_thread;
};

}  // namespace dembuf::server
