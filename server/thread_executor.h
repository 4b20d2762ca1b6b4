// The thread executor: the job queue and the daemon's worker threads that run it. The queue is the
// one a local sweep uses (RunQueue): jobs run oldest first, except that a job whose bed is being
// prepared by a running job waits for that bed (its completion wakes the queue) while the workers
// take other jobs, so a bed is prepared once, by one worker; the workers' cores are shared among
// the running jobs.
#pragma once

#include <spdlog/logger.h>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "dembuf/study/bed/bed.h"
#include "dembuf/study/sweep/run_queue.h"
#include "executor.h"

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
  void WorkerLoop(int worker);
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
  std::vector<std::jthread> m_workers;
};

}  // namespace dembuf::server
