#include "call_pool.h"

#include <algorithm>

namespace dembuf::server {

CallPool::CallPool(int threads, std::size_t max_waiting_per_user)
    : m_max_waiting(max_waiting_per_user) {
  for (int t = 0; t < std::max(threads, 1); ++t) m_workers.emplace_back([this] { Work(); });
}

CallPool::~CallPool() {
  {
    std::lock_guard lock(m_mutex);
    m_stopping = true;
  }
  m_changed.notify_all();
  for (std::thread& worker : m_workers) worker.join();
}

bool CallPool::Queue(const std::string& user, std::function<void()> work) {
  {
    std::lock_guard lock(m_mutex);
    std::deque<std::function<void()>>& mine = m_waiting[user];
    if (mine.size() >= m_max_waiting) return false;
    if (mine.empty()) m_turns.push_back(user);
    mine.push_back(std::move(work));
  }
  m_changed.notify_one();
  return true;
}

void CallPool::Work() {
  std::unique_lock lock(m_mutex);
  for (;;) {
    m_changed.wait(lock, [&] { return m_stopping || !m_turns.empty(); });
    // Stopping: the calls waiting still run (each must be answered), then the workers end.
    if (m_turns.empty()) return;
    // The user whose turn it is gives one call, and waits for a turn again behind the others.
    const std::string user = m_turns.front();
    m_turns.pop_front();
    std::deque<std::function<void()>>& mine = m_waiting[user];
    std::function<void()> work = std::move(mine.front());
    mine.pop_front();
    if (mine.empty())
      m_waiting.erase(user);
    else
      m_turns.push_back(user);
    lock.unlock();
    try {
      work();
    } catch (...) {
      // the service answers every failure itself (Guard); nothing may end a worker
    }
    lock.lock();
  }
}

}  // namespace dembuf::server
