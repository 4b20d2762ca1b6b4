#include "doors/stream_clock.h"

namespace dembuf::server {

StreamClock::StreamClock() : m_thread([this] { Run(); }) {}

StreamClock::~StreamClock() {
  {
    std::lock_guard lock(m_mutex);
    m_stopping = true;
  }
  m_wake.notify_all();
  m_thread.join();
}

void StreamClock::At(Clock::time_point when, std::function<void()> task) {
  {
    std::lock_guard lock(m_mutex);
    m_entries.push({when, m_next_order++, std::move(task)});
  }
  m_wake.notify_one();
}

void StreamClock::Run() {
  std::unique_lock lock(m_mutex);
  while (!m_stopping) {
    if (m_entries.empty()) {
      m_wake.wait(lock);
      continue;
    }
    if (m_entries.top().when > Clock::now()) {
      m_wake.wait_until(lock, m_entries.top().when);
      continue;
    }
    // (The queue's top is const: its task is copied out, once per run.)
    std::function<void()> task = m_entries.top().task;
    m_entries.pop();
    lock.unlock();
    task();
    lock.lock();
  }
}

}  // namespace dembuf::server
