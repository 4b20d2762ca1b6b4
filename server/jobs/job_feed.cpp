#include "jobs/job_feed.h"

#include <algorithm>
#include <thread>

namespace dembuf::server {

JobProgress ProgressOf(const JobRecord& job, Executor& executor) {
  if (auto live = executor.Live(job.id)) return live->Progress();
  JobProgress progress;
  progress.stage = job.state == JobState::kDone ? "done" : StateName(job.state);
  progress.fraction = job.state == JobState::kDone ? 1.0 : 0.0;
  // An ended job's peak is its summary's, kept in its record (0 where it is not known).
  progress.peak_plate_force_N = job.peak_plate_force_N.value_or(0.0);
  return progress;
}

double JobFeed::StoredPeak() {
  if (!m_stored_peak) {
    // A finished job's peak is its summary's, of every step, kept in its record, as every
    // door says it (the samples are every output interval, and missed the top by a few
    // newtons).
    if (const std::optional<JobRecord> job = m_store.GetJob(m_id); job && job->peak_plate_force_N)
      return *(m_stored_peak = *job->peak_plate_force_N);
    // Not known (an older job's damaged summary): the samples say what they can.
    // Piece by piece: a long series is never held whole.
    constexpr std::int64_t kPiece = 1 << 14;
    double peak = 0.0;
    for (std::int64_t from = 0;; from += kPiece) {
      const std::vector<ImpactSample> piece = m_store.ReadResultSeries(m_id, from, kPiece);
      for (const ImpactSample& s : piece) peak = std::max(peak, s.plate_force_N);
      if (static_cast<std::int64_t>(piece.size()) < kPiece) break;
    }
    m_stored_peak = peak;
  }
  return *m_stored_peak;
}

FeedRead JobFeed::Read(std::int64_t from, std::size_t max, std::chrono::milliseconds wait) {
  const auto deadline = std::chrono::steady_clock::now() + wait;
  for (;;) {
    FeedRead out;
    // A running job is read live; else the store has the final word.
    if (auto live = m_executor.Live(m_id)) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
          deadline - std::chrono::steady_clock::now());
      LiveRead read =
          live->Read(static_cast<std::size_t>(from), max, std::max(left, decltype(left){0}));
      out.state = read.state;
      out.progress = read.progress;
      // Already stored by the worker: a watcher that came late or fell behind.
      out.samples = read.stored ? m_store.ReadSeries(m_id, from, static_cast<std::int64_t>(max))
                                : std::move(read.samples);
      out.ended = read.ended && IsFinal(read.state);
      if (out.ended && out.state == JobState::kDone) out.progress.peak_plate_force_N = StoredPeak();
      // Ended but not final: back to the queue (a shutdown); the worker lets go of it soon.
      if (read.ended && !IsFinal(read.state))
        std::this_thread::sleep_for(std::chrono::milliseconds(100));
      return out;
    }
    const std::optional<JobRecord> job = m_store.GetJob(m_id);
    if (!job) {
      out.found = false;
      return out;
    }
    out.state = job->state;
    out.progress = ProgressOf(*job, m_executor);
    if (IsFinal(job->state)) {
      out.samples = m_store.ReadResultSeries(m_id, from, static_cast<std::int64_t>(max));
      out.progress.peak_plate_force_N = StoredPeak();
      out.ended = out.samples.size() < max;
      return out;
    }
    // Queued, or about to start: wait for a worker, in short naps so that its start is seen.
    if (std::chrono::steady_clock::now() >= deadline) return out;
    std::this_thread::sleep_for(std::min<std::chrono::steady_clock::duration>(
        std::chrono::milliseconds(100), deadline - std::chrono::steady_clock::now()));
  }
}

}  // namespace dembuf::server
