// The thread executor: the job queue and the daemon's workers that run it, the queue and pool a
// local sweep uses too (RunQueue, QueueWorkers): the users take turns, a job whose bed a running
// job is preparing waits for that bed (its completion wakes the queue) while the workers take
// other jobs, so a bed is prepared once, by one worker; the workers' cores are shared among the
// running jobs.
#pragma once

#include <spdlog/logger.h>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "dembuf/study/bed/bed.h"
#include "dembuf/study/sweep/run_queue.h"
#include "jobs/executor.h"

namespace dembuf::server {

struct ThreadExecutorOptions {
  int workers = 1;
  int threads_per_job = 1;
  int queue_limit = 1000;  ///< queued jobs at most
  /// After a job could not be stored because the disk was full, the workers wait this long
  /// before taking a job again.
  std::chrono::seconds storage_retry{30};
  std::string host;
};

class ThreadExecutor final : public Executor {
 public:
  ThreadExecutor(Store& store, ThreadExecutorOptions options, std::shared_ptr<spdlog::logger> log);
  ~ThreadExecutor() override;

  /// Re-queues the jobs a previous daemon left running, loads the queue, starts the workers.
  void Start() override;

  /// Stores new jobs (with `add`, which inserts them into the database) and queues them, if
  /// the queue has room for `count` more; else throws QueueFull and stores nothing.
  void Admit(std::size_t count, const std::function<std::vector<JobRecord>()>& add) override;

  /// Cancels a queued or running job. False if it had already ended.
  bool Cancel(std::int64_t id) override;

  /// The job while it runs (null when queued or ended).
  std::shared_ptr<LiveJob> Live(std::int64_t id) override;

  int queued() const override { return static_cast<int>(m_queue.queued()); }
  int running() const override;
  ExecutorInfo info() const override {
    return {"threads", m_options.workers, m_options.threads_per_job, m_options.queue_limit};
  }

  /// Stops taking jobs; waits up to `grace` for the running ones, then interrupts them and
  /// puts them back in the queue for the next start. Returns when every worker has stopped.
  void Shutdown(std::chrono::seconds grace) override;

 private:
  /// Runs a job the queue handed to worker `worker`: whatever happens, the job ends with a
  /// state, or is queued again when the disk is full.
  QueueWorkers::RunEnd RunTaken(std::int64_t id, int worker);
  /// The job no longer holds cores of the queue: its LiveJob (whose `threads` the queue wrote)
  /// leaves m_running.
  void EndTaken(std::int64_t id, int worker);
  /// The job's live state, made as the queue hands the job to a worker.
  std::atomic<int>* StartLive(std::int64_t id);
  void Run(std::int64_t id, const std::shared_ptr<LiveJob>& live);
  /// Something outside the job's own run failed (the database, say): the job fails with the
  /// reason, and the worker goes on.
  void FailAfterError(std::int64_t id, const std::shared_ptr<LiveJob>& live,
                      const std::string& what);
  /// The database's disk is full: puts the job back at the head of the queue and pauses the
  /// workers for storage_retry, so that nothing is lost and nothing spins.
  void RequeueForStorage(std::int64_t id, const std::shared_ptr<LiveJob>& live,
                         const StorageFull& error);

  Store& m_store;
  ThreadExecutorOptions m_options;
  std::shared_ptr<spdlog::logger> m_log;
  BedCache m_beds;
  RunQueue m_queue;

  // Never held while calling m_queue (the queue calls StartLive under its own lock).
  mutable std::mutex m_mutex;
  std::condition_variable m_ended;  ///< a running job has ended
  std::map<std::int64_t, std::shared_ptr<LiveJob>> m_running;
  bool m_stopping = false;
  std::mutex m_admit_mutex;
  /// Each worker's job while the queue may still write its threads (the worker's own slot).
  std::vector<std::shared_ptr<LiveJob>> m_taken;
  std::optional<QueueWorkers> m_workers;
};

}  // namespace dembuf::server
