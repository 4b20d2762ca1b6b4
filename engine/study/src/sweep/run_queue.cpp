#include "dembuf/study/sweep/run_queue.h"

#include <omp.h>

#include <algorithm>
#include <vector>

namespace dembuf {

RunQueue::RunQueue(BedCache& beds, int cores, const std::atomic<bool>* cancel)
    : m_beds(beds), m_cores(std::max(cores, 1)), m_cancel(cancel) {}

void RunQueue::Push(Id id, const Needs& needs) {
  {
    std::lock_guard lock(m_mutex);
    m_queue.push_back({id, needs});
  }
  m_changed.notify_all();
}

void RunQueue::PushFront(Id id, const Needs& needs) {
  {
    std::lock_guard lock(m_mutex);
    m_queue.push_front({id, needs});
  }
  m_changed.notify_all();
}

std::optional<RunQueue::Needs> RunQueue::Remove(Id id) {
  std::lock_guard lock(m_mutex);
  const auto it =
      std::find_if(m_queue.begin(), m_queue.end(), [&](const Entry& e) { return e.id == id; });
  if (it == m_queue.end()) return std::nullopt;
  Needs needs = it->needs;
  m_queue.erase(it);
  ShareCoresLocked();  // a run that waited for a bed no longer does
  return needs;
}

void RunQueue::Requeue(Id id) {
  {
    std::lock_guard lock(m_mutex);
    const auto it = m_running.find(id);
    if (it == m_running.end()) return;
    m_queue.push_front({id, it->second.needs});
    m_running.erase(it);
    ShareCoresLocked();
  }
  m_changed.notify_all();
}

std::vector<BedNeeds> RunQueue::BusyLocked() const {
  std::vector<BedNeeds> busy;
  for (const auto& [id, running] : m_running) busy.push_back(running.needs.beds);
  return busy;
}

std::optional<RunQueue::Id> RunQueue::Next(const std::function<std::atomic<int>*(Id)>& start) {
  std::unique_lock lock(m_mutex);
  while (true) {
    if (m_stopped || (m_cancel && m_cancel->load())) return std::nullopt;
    if (m_queue.empty() && m_closed) return std::nullopt;
    if (Clock::now() < m_paused_until) {
      m_changed.wait_until(lock, m_paused_until);
      continue;
    }
    // A run gets a core at least: more runs than cores would wait for each other at every
    // step (8 runs on 2 cores took 3.3 times as long as 2).
    if (m_running.size() < static_cast<std::size_t>(m_cores)) {
      // Each owner's first run that may start now competes; the owner whose last run started
      // longest ago (or never) wins, the earlier run on a tie. A bed another worker is
      // preparing will be ready soon: preparing it twice would waste a worker, and waiting for
      // it would idle one, so a run waiting for one is passed over.
      const std::vector<BedNeeds> busy = BusyLocked();
      std::map<std::string, bool> seen;  // owners whose first run that may start is found
      auto chosen = m_queue.end();
      std::uint64_t chosen_turn = 0;
      for (auto it = m_queue.begin(); it != m_queue.end(); ++it) {
        if (seen.count(it->needs.owner) || WaitsForBed(it->needs.beds, busy, m_beds)) continue;
        seen[it->needs.owner] = true;
        const auto last = m_last_start.find(it->needs.owner);
        const std::uint64_t turn = last == m_last_start.end() ? 0 : last->second;
        if (chosen == m_queue.end() || turn < chosen_turn) {
          chosen = it;
          chosen_turn = turn;
          if (turn == 0) break;  // an owner with no run started yet: none comes before it
        }
      }
      if (chosen != m_queue.end()) {
        const Entry run = *chosen;
        m_queue.erase(chosen);
        m_last_start[run.needs.owner] = ++m_starts;
        m_running[run.id] = {run.needs, start(run.id)};
        ShareCoresLocked();
        return run.id;
      }
    }
    // Nothing may start: wait for a new run, an ended one or a prepared bed. The timeout
    // covers a cancel flag set by a signal handler and a bed stored by another process.
    m_changed.wait_for(lock, std::chrono::seconds(1));
  }
}

void RunQueue::Done(Id id) {
  {
    std::lock_guard lock(m_mutex);
    m_running.erase(id);
    ShareCoresLocked();
  }
  m_changed.notify_all();
}

void RunQueue::ShareCoresLocked() {
  std::vector<CoreClaim> claims;
  for (const auto& [id, run] : m_running) {
    // A running run whose source bed is not ready is the one preparing it (WaitsForBed).
    const std::string& source = run.needs.beds.source_hash;
    const bool preparing = !source.empty() && !m_beds.Contains(source);
    CoreClaim claim{ThreadsMax(run.needs.load, preparing, m_cores), 0};
    if (preparing)
      claim.waiting =
          static_cast<int>(std::count_if(m_queue.begin(), m_queue.end(), [&](const Entry& e) {
            return e.needs.beds.source_hash == source;
          }));
    claims.push_back(claim);
  }
  const std::vector<int> threads = ShareCores(m_cores, claims);
  std::size_t k = 0;
  for (auto& [id, run] : m_running) {
    if (run.threads) *run.threads = threads[k];
    ++k;
  }
}

void RunQueue::Close() {
  {
    std::lock_guard lock(m_mutex);
    m_closed = true;
  }
  m_changed.notify_all();
}

void RunQueue::Stop() {
  {
    std::lock_guard lock(m_mutex);
    m_stopped = true;
  }
  m_changed.notify_all();
}

void RunQueue::PauseUntil(Clock::time_point until) {
  std::lock_guard lock(m_mutex);
  m_paused_until = until;
}

void RunQueue::Wake() {
  {
    std::lock_guard lock(m_mutex);
    ShareCoresLocked();
  }
  m_changed.notify_all();
}

std::size_t RunQueue::queued() const {
  std::lock_guard lock(m_mutex);
  return m_queue.size();
}

std::size_t RunQueue::running() const {
  std::lock_guard lock(m_mutex);
  return m_running.size();
}

QueueWorkers::QueueWorkers(RunQueue& queue, int workers, Work work)
    : m_queue(queue), m_work(std::move(work)) {
  for (int worker = 0; worker < workers; ++worker)
    m_threads.emplace_back([this, worker] { Loop(worker); });
}

void QueueWorkers::Loop(int worker) {
  omp_set_num_threads(m_work.omp_threads);  // a per-thread setting
  std::atomic<int>* threads = nullptr;
  while (const std::optional<RunQueue::Id> id = m_queue.Next(
             [&](RunQueue::Id started) { return threads = m_work.start(started, worker); })) {
    if (m_work.run(*id, worker, threads) == RunEnd::kDone) m_queue.Done(*id);
    if (m_work.ended) m_work.ended(*id, worker);
  }
}

}  // namespace dembuf
