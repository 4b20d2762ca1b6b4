// Where jobs run: on the daemon's own worker threads (ThreadExecutor) or as jobs of the lab's
// Slurm cluster (SlurmExecutor). Both take jobs stored in the database, keep their state
// there, and hold a LiveJob for every running job, which `watch` reads.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "jobs/live_job.h"
#include "store/store.h"

namespace dembuf::server {

/// The queue cannot take the jobs.
class QueueFull : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Throws QueueFull when `count` more jobs would take a queue holding `queued` past `limit`.
inline void CheckQueueRoom(std::size_t queued, std::size_t count, int limit) {
  if (queued + count > static_cast<std::size_t>(limit))
    throw QueueFull("the queue holds " + std::to_string(queued) + " jobs; " +
                    std::to_string(count) + " more would pass its limit of " +
                    std::to_string(limit));
}

/// What server-info shows of an executor.
struct ExecutorInfo {
  std::string kind;  ///< "threads" or "slurm"
  int workers = 0;   ///< jobs run at once (threads); 0: as many as the cluster places
  int threads_per_job = 1;
  int queue_limit = 0;
};

class Executor {
 public:
  virtual ~Executor() = default;

  /// Takes up the jobs a previous daemon left, and starts.
  virtual void Start() = 0;
  /// Stores new jobs (with `add`, which inserts them into the database) and queues them, if
  /// the queue has room for `count` more; else throws QueueFull and stores nothing.
  virtual void Admit(std::size_t count, const std::function<std::vector<JobRecord>()>& add) = 0;
  /// Cancels a queued or running job. False if it had already ended.
  virtual bool Cancel(std::int64_t id) = 0;
  /// The job while it runs (null when queued or ended).
  virtual std::shared_ptr<LiveJob> Live(std::int64_t id) = 0;
  virtual int queued() const = 0;
  virtual int running() const = 0;
  virtual ExecutorInfo info() const = 0;
  /// A prepared bed pushed to the daemon, already in the store: an executor that reads beds
  /// from elsewhere (a cluster's folder) puts it there too.
  virtual void AddBed(const PreparedBed&) {}
  /// Stops taking jobs and waits up to `grace` for what runs here.
  virtual void Shutdown(std::chrono::seconds grace) = 0;
};

}  // namespace dembuf::server
