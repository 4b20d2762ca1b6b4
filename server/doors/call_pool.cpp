#include "doors/call_pool.h"

#include <algorithm>

namespace dembuf::server {

CallPool::CallPool(int threads, std::size_t max_running_per_user, std::size_t max_waiting_per_user)
    : m_max_running(std::max<std::size_t>(max_running_per_user, 1)),
      m_max_waiting(max_waiting_per_user) {
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
    // The first user in turn with fewer than m_max_running calls running.
    auto turn = m_turns.end();
    m_changed.wait(lock, [&] {
      turn = std::find_if(m_turns.begin(), m_turns.end(), [&](const std::string& user) {
        const auto running = m_running.find(user);
        return running == m_running.end() || running->second < m_max_running;
      });
      return turn != m_turns.end() || (m_stopping && m_turns.empty());
    });
    // Stopping: the calls waiting still run (each must be answered), then the workers end.
    if (turn == m_turns.end()) return;
    // The user whose turn it is gives one call, and waits for a turn again behind the others.
    const std::string user = *turn;
    m_turns.erase(turn);
    std::deque<std::function<void()>>& mine = m_waiting[user];
    std::function<void()> work = std::move(mine.front());
    mine.pop_front();
    if (mine.empty())
      m_waiting.erase(user);
    else
      m_turns.push_back(user);
    ++m_running[user];
    lock.unlock();
    try {
      work();
    } catch (...) {
      // the service answers every failure itself (Guard); nothing may end a worker
    }
    lock.lock();
    if (--m_running[user] == 0) m_running.erase(user);
    m_changed.notify_all();  // that user's next call may go
  }
}

}  // namespace dembuf::server
