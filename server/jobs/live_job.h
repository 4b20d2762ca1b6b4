// A job while a worker runs it: its samples not yet stored, its state and progress, and its
// cancel flag. Any number of watchers read it while the worker appends; the worker stores the
// samples in chunks as they come (Store::AppendSeries) and then drops them here, so a watcher
// that joins late or falls behind reads the earlier ones from the store (LiveRead::stored).
#pragma once

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <string>
#include <vector>

#include "dembuf/study/impact/impact.h"
#include "store/store.h"

namespace dembuf::server {

struct JobProgress {
  std::string stage = "queued";
  double fraction = 0.0;
  double sim_time_s = 0.0;
  std::int64_t steps = 0;
  double peak_plate_force_N = 0.0;
};

/// What a watcher gets from one read.
struct LiveRead {
  std::vector<ImpactSample> samples;  ///< from the requested index on
  JobState state = JobState::kQueued;
  JobProgress progress;
  bool ended = false;   ///< no more samples will come
  bool stored = false;  ///< the requested samples are no longer here: read them from the store
};

class LiveJob {
 public:
  /// `first_sample`: how many of its samples are stored already (a job taken up again).
  explicit LiveJob(std::int64_t id, std::int64_t first_sample = 0)
      : m_id(id), m_first(first_sample) {}

  std::int64_t id() const { return m_id; }

  void Append(const ImpactSample& sample) {
    {
      std::lock_guard lock(m_mutex);
      m_samples.push_back(sample);
      m_progress.peak_plate_force_N = std::max(m_progress.peak_plate_force_N, sample.plate_force_N);
    }
    m_changed.notify_all();
  }

  /// How many samples are held here, not yet stored.
  std::size_t Unstored() const {
    std::lock_guard lock(m_mutex);
    return m_samples.size();
  }

  /// The samples not yet stored and the index of the first of them.
  std::pair<std::int64_t, std::vector<ImpactSample>> UnstoredSamples() const {
    std::lock_guard lock(m_mutex);
    return {m_first, m_samples};
  }

  /// The samples before index `end` are in the store: drop them here.
  void Stored(std::int64_t end) {
    std::lock_guard lock(m_mutex);
    const auto drop =
        static_cast<std::size_t>(std::clamp<std::int64_t>(end - m_first, 0, m_samples.size()));
    m_samples.erase(m_samples.begin(), m_samples.begin() + drop);
    m_first += static_cast<std::int64_t>(drop);
  }

  void SetState(JobState state) {
    {
      std::lock_guard lock(m_mutex);
      m_state = state;
      // Until the run reports its own stage, its stage is its state ("preparing_bed", not the
      // "queued" it was made with).
      if (!m_stage_reported) m_progress.stage = StateName(state);
    }
    m_changed.notify_all();
  }

  void SetProgress(const std::string& stage, double fraction, double sim_time_s,
                   std::int64_t steps) {
    std::lock_guard lock(m_mutex);
    m_stage_reported = true;
    m_progress.stage = stage;
    m_progress.fraction = fraction;
    m_progress.sim_time_s = sim_time_s;
    m_progress.steps = steps;
  }

  /// No more samples: the job ended in `state` (or went back to the queue).
  void End(JobState state) {
    {
      std::lock_guard lock(m_mutex);
      m_state = state;
      m_ended = true;
    }
    m_changed.notify_all();
  }

  /// Samples from index `from` (at most `max`), waiting up to `wait` for some to arrive
  /// unless there are some already or the job has ended.
  LiveRead Read(std::size_t from, std::size_t max, std::chrono::milliseconds wait) {
    std::unique_lock lock(m_mutex);
    const auto index = static_cast<std::int64_t>(from);
    auto count = [&] { return m_first + static_cast<std::int64_t>(m_samples.size()); };
    m_changed.wait_for(lock, wait, [&] { return m_ended || count() > index || index < m_first; });
    LiveRead read;
    read.state = m_state;
    read.progress = m_progress;
    if (index < m_first) {
      read.stored = true;
      return read;
    }
    const auto begin = static_cast<std::size_t>(index - m_first);
    const std::size_t end = std::min(m_samples.size(), begin + max);
    if (begin < end) read.samples.assign(m_samples.begin() + begin, m_samples.begin() + end);
    read.ended = m_ended && end == m_samples.size();
    return read;
  }

  JobProgress Progress() const {
    std::lock_guard lock(m_mutex);
    return m_progress;
  }

  /// Raised to stop the run; the engine checks it every few steps.
  std::atomic<bool> cancel{false};
  /// Why it was raised: false by the user, true by the daemon shutting down.
  std::atomic<bool> cancel_for_shutdown{false};
  /// Engine threads the run may use now; the scheduler lends it the cores of idle workers.
  std::atomic<int> threads{1};

 private:
  const std::int64_t m_id;
  mutable std::mutex m_mutex;
  std::condition_variable m_changed;
  std::vector<ImpactSample> m_samples;  ///< from index m_first on; the earlier ones are stored
  std::int64_t m_first;
  JobState m_state = JobState::kQueued;
  JobProgress m_progress;
  bool m_stage_reported = false;
  bool m_ended = false;
};

}  // namespace dembuf::server
