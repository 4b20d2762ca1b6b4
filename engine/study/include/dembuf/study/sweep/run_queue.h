// The queue of runs that parallel workers take from (RunQueue), and those workers (QueueWorkers):
// a local sweep's and the daemon's alike. Runs go in their order, their owners in turn (the
// daemon's users: the owner whose last run started longest ago goes first, so that one user's
// 10,000 runs do not hold back another's one run for more than a run's time), except that a run
// whose bed another running run is preparing is passed over (WaitsForBed) while the workers take
// others, so a bed is prepared once, by one worker; when every run left waits, a worker sleeps
// until a bed is ready or a run ends. The machine's cores are shared among the running runs by what
// each can use (ShareCores): a run preparing a source bed others wait for gets the cores its beds
// can feed first, and cores no run can feed stay free. No more runs go at once than there are
// cores: workers beyond them wait for a core.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "dembuf/study/bed/bed.h"
#include "dembuf/study/sweep/schedule.h"

namespace dembuf {

class RunQueue {
 public:
  using Id = std::int64_t;
  using Clock = std::chrono::steady_clock;
  /// What the queue knows of a run: the beds it needs, how many threads they can feed
  /// (without a load, it may take every core), and whose it is ("" for a local sweep's).
  struct Needs {
    BedNeeds beds;
    RunLoad load;
    std::string owner{};
  };

  /// Runs share `cores` engine threads, at most `cores` runs at once; `beds` tells which beds
  /// are ready. A set `cancel`
  /// makes Next return nothing (checked at least once a second).
  RunQueue(BedCache& beds, int cores, const std::atomic<bool>* cancel = nullptr);

  /// Adds a run at the back, or at the front (a run that keeps its turn).
  void Push(Id id, const Needs& needs);
  void PushFront(Id id, const Needs& needs);
  /// Takes a queued run out; its needs, or nothing if it is not queued.
  std::optional<Needs> Remove(Id id);
  /// Puts a running run back at the front (it could not finish now and keeps its turn).
  void Requeue(Id id);

  /// Blocks until a run may start and returns it, having called start(id), which returns
  /// where the run's share of the cores is to be written (kept up to date until Done). start
  /// runs under the queue's lock, so the run is never seen neither queued nor started.
  /// Returns nothing once the queue is stopped, cancelled, or closed and empty.
  std::optional<Id> Next(const std::function<std::atomic<int>*(Id)>& start);
  /// The run has ended; its cores go to the others.
  void Done(Id id);

  /// No more runs will be pushed: Next returns nothing once the queue is empty.
  void Close();
  /// Next returns nothing from now on (runs left stay queued).
  void Stop();
  /// No run starts before `until` (the workers pause, e.g. while the disk is full).
  void PauseUntil(Clock::time_point until);
  /// Something a waiting run may need has changed (a bed was prepared): the runs waiting
  /// for it may go, and the cores are shared again.
  void Wake();

  std::size_t queued() const;
  std::size_t running() const;

 private:
  struct Entry {
    Id id;
    Needs needs;
  };
  struct Running {
    Needs needs;
    std::atomic<int>* threads;
  };
  /// The beds the running runs are preparing or use (what a queued run may wait for).
  std::vector<BedNeeds> BusyLocked() const;
  void ShareCoresLocked();

  BedCache& m_beds;
  const int m_cores;
  const std::atomic<bool>* m_cancel;
  mutable std::mutex m_mutex;
  std::condition_variable m_changed;
  std::deque<Entry> m_queue;
  std::map<Id, Running> m_running;
  /// When each owner's last run started (a count of starts): the smallest goes next.
  std::map<std::string, std::uint64_t> m_last_start;
  std::uint64_t m_starts = 0;
  bool m_closed = false;
  bool m_stopped = false;
  Clock::time_point m_paused_until{};
};

/// The workers of one RunQueue, for a local sweep and the daemon alike: plain threads, each
/// taking runs (RunQueue::Next) until the queue has none for it. Each opens its engine's OpenMP
/// teams at the top level: libgomp starts a nested team's threads afresh at every parallel
/// region (122 us a region against 1 us, measured on a 2-vCPU machine), which made a bed
/// prepared inside a sweep up to 5 times as slow as the same bed alone.
class QueueWorkers {
 public:
  /// How a run left its worker: done (the worker tells the queue, and its cores go to the
  /// others), or put back in the queue by `run` itself (RunQueue::Requeue), keeping its turn.
  enum class RunEnd { kDone, kRequeued };
  struct Work {
    /// Called as a run starts, under the queue's lock (RunQueue::Next's `start`): where the
    /// run's share of the cores is to be written.
    std::function<std::atomic<int>*(RunQueue::Id, int worker)> start;
    /// Runs it, in worker `worker`'s thread, its share of the cores in `threads`. It must not
    /// throw: nothing may leave a worker.
    std::function<RunEnd(RunQueue::Id, int worker, const std::atomic<int>* threads)> run;
    /// Called (optional) once the queue no longer counts the run (after RunQueue::Done, or
    /// after `run` requeued it): from then on, what `start` returned may go.
    std::function<void(RunQueue::Id, int worker)> ended{};
    /// The OpenMP threads of the worker's thread (omp_set_num_threads): what an engine part
    /// uses that is not given `threads` (the bare-plate run, say).
    int omp_threads = 1;
  };

  /// Starts `workers` threads on `queue`, which must outlive them.
  QueueWorkers(RunQueue& queue, int workers, Work work);
  QueueWorkers(const QueueWorkers&) = delete;
  QueueWorkers& operator=(const QueueWorkers&) = delete;
  ~QueueWorkers() { Join(); }
  /// Waits for every worker to end: until the queue is closed and empty, or stopped (call
  /// RunQueue::Close or Stop first, or this waits for ever).
  void Join() { m_threads.clear(); }
  bool joined() const { return m_threads.empty(); }

 private:
  void Loop(int worker);

  RunQueue& m_queue;
  const Work m_work;
  std::vector<std::jthread> m_threads;
};

}  // namespace dembuf
