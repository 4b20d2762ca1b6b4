// A job's force samples, state and progress for whoever watches it, from wherever they are
// now: the running job's memory (its LiveJob) while it runs, the store before and after. The
// gRPC watch stream and the web pages' event stream both read through it, so they tell the
// same story.
#pragma once

#include <chrono>
#include <cstdint>
#include <optional>
#include <vector>

#include "jobs/executor.h"
#include "jobs/live_job.h"
#include "store/store.h"

namespace dembuf::server {

/// The job's progress as users see it: the running job's own, else what its stored state says.
JobProgress ProgressOf(const JobRecord& job, Executor& executor);

/// What one read of a feed gives.
struct FeedRead {
  bool found = true;                  ///< false: there is no such job
  std::vector<ImpactSample> samples;  ///< from the index asked for on
  JobState state = JobState::kQueued;
  JobProgress progress;
  bool ended = false;  ///< the job has ended and these were its last samples
};

class JobFeed {
 public:
  JobFeed(Store& store, Executor& executor, std::int64_t id)
      : m_store(store), m_executor(executor), m_id(id) {}

  /// Up to `max` samples from index `from` on. While the job waits or runs and has none past
  /// `from`, waits up to `wait` for some (returning as soon as they come).
  FeedRead Read(std::int64_t from, std::size_t max, std::chrono::milliseconds wait);

 private:
  /// An ended job's peak plate force, read once: its record's (the summary's, of every step),
  /// else the highest of its stored series.
  double StoredPeak();

  Store& m_store;
  Executor& m_executor;
  const std::int64_t m_id;
  std::optional<double> m_stored_peak;
};

}  // namespace dembuf::server
