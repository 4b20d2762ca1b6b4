#include "jobs/thread_executor.h"

#include <algorithm>

#include "dembuf/core/threads.h"
#include "dembuf/study/files/run_output.h"
#include "dembuf/study/files/snapshot_report.h"
#include "dembuf/study/run/job_progress.h"
#include "dembuf/study/run/resource_estimate.h"
#include "dembuf/study/run/run_job.h"
#include "dembuf/study/scene/errors.h"
#include "dembuf/study/scene/scene_fields.h"
#include "dembuf/study/version.h"
#include "jobs/job_scene.h"
#include "jobs/store_recorder.h"
#include "store/fault_injection.h"

namespace dembuf::server {

namespace {

// The job the calling worker thread runs: beds are prepared inside the engine, in the
// worker's thread, and the cache's callback uses this to record who prepared them.
thread_local std::int64_t t_current_job = 0;

// How often the engine reports progress and checks the cancel flag, in steps: a few
// milliseconds even for the largest beds, so that a cancel takes effect within a second.
constexpr std::int64_t kProgressEverySteps = 64;

// What the queue needs to know of a job: its beds, how many threads they can feed, and its
// owner (users take turns). A scene the estimate cannot take (a bed file gone) fails when it
// runs, and may take any core.
RunQueue::Needs QueueNeeds(Store& store, const JobRecord& job) {
  RunQueue::Needs needs{{job.source_hash, job.bed_hash}, {}, job.owner};
  try {
    const Scene scene = SceneOfJob(store, job);
    needs.load = LoadOf(EstimateResources(scene), job.source_hash);
  } catch (const std::exception&) {
    needs.load.source_hash = job.source_hash;
  }
  return needs;
}

}  // namespace

ThreadExecutor::ThreadExecutor(Store& store, ThreadExecutorOptions options,
                               std::shared_ptr<spdlog::logger> log)
    : m_store(store),
      m_options(std::move(options)),
      m_log(std::move(log)),
      m_beds(std::shared_ptr<BedStore>(&store.beds(), [](BedStore*) {}), 4),
      m_queue(m_beds, std::min(m_options.workers * m_options.threads_per_job, dem::UsableCpus())) {
  m_beds.OnPrepared([this](const PreparedBed& bed) {
    if (t_current_job != 0) m_store.RecordBedPreparation(bed.hash, bed.stage, t_current_job);
    m_log->info("job {}: prepared the {} bed {} ({} beads, H = {:.4f} m, C0 = {:.3f})",
                t_current_job, bed.stage, bed.hash, bed.beads.size(), bed.surface_m,
                bed.solid_fraction);
    m_queue.Wake();  // jobs waiting for this bed may go
  });
}

ThreadExecutor::~ThreadExecutor() {
  Shutdown(std::chrono::seconds(0));
}

void ThreadExecutor::Start() {
  const InterruptedJobs interrupted = m_store.RequeueInterrupted(
      "interrupted: the daemon stopped while this job ran; it runs again from the start");
  for (const JobRecord& job : interrupted.requeued)
    m_log->warn("job {} was {} when the daemon stopped; queued to run again (attempt {})", job.id,
                StateName(job.state), job.attempts + 1);
  for (const JobRecord& job : interrupted.poisoned)
    m_log->error(
        "job {} was {} when the daemon stopped, for the second time: failed as a poison job, "
        "not run again",
        job.id, StateName(job.state));
  for (const JobRecord& job : m_store.QueuedJobs()) m_queue.Push(job.id, QueueNeeds(m_store, job));
  m_log->info("{} jobs queued; starting {} workers with {} threads each", m_queue.queued(),
              m_options.workers, m_options.threads_per_job);
  QueueWorkers::Work work;
  work.start = [this](std::int64_t job, int) { return StartLive(job); };
  work.run = [this](std::int64_t job, int worker, const std::atomic<int>*) {
    return RunTaken(job, worker);
  };
  work.ended = [this](std::int64_t job, int worker) { EndTaken(job, worker); };
  work.omp_threads = m_options.threads_per_job;  // each job's engine uses this many
  m_taken.resize(static_cast<std::size_t>(m_options.workers));
  m_workers.emplace(m_queue, m_options.workers, std::move(work));
}

void ThreadExecutor::Admit(std::size_t count, const std::function<std::vector<JobRecord>()>& add) {
  std::lock_guard admit(m_admit_mutex);  // one admission at a time: the check stays true
  {
    std::lock_guard lock(m_mutex);
    if (m_stopping) throw QueueFull("the daemon is shutting down");
  }
  CheckQueueRoom(m_queue.queued(), count, m_options.queue_limit);
  for (const JobRecord& job : add()) m_queue.Push(job.id, QueueNeeds(m_store, job));
}

bool ThreadExecutor::Cancel(std::int64_t id) {
  if (const std::optional<RunQueue::Needs> needs = m_queue.Remove(id)) {
    try {
      m_store.FinishJob(id, JobState::kCancelled, "cancelled while queued", {});
    } catch (const StorageFull&) {
      m_queue.PushFront(id, *needs);  // not cancelled after all: it keeps its turn
      throw;
    }
    m_log->info("job {}: cancelled while queued", id);
    return true;
  }
  // Not queued: running (a job leaves the queue and enters m_running in one step), or ended.
  std::lock_guard lock(m_mutex);
  if (auto running = m_running.find(id); running != m_running.end()) {
    running->second->cancel = true;
    m_log->info("job {}: cancel requested", id);
    return true;
  }
  return false;
}

std::shared_ptr<LiveJob> ThreadExecutor::Live(std::int64_t id) {
  std::lock_guard lock(m_mutex);
  auto it = m_running.find(id);
  return it == m_running.end() ? nullptr : it->second;
}

int ThreadExecutor::running() const {
  std::lock_guard lock(m_mutex);
  return static_cast<int>(m_running.size());
}

void ThreadExecutor::Shutdown(std::chrono::seconds grace) {
  {
    std::lock_guard lock(m_mutex);
    if (m_stopping && !m_workers) return;
    m_stopping = true;
  }
  m_queue.Stop();
  const auto deadline = std::chrono::steady_clock::now() + grace;
  {
    std::unique_lock lock(m_mutex);
    if (!m_running.empty())
      m_log->info("waiting up to {} s for {} running jobs", grace.count(), m_running.size());
    m_ended.wait_until(lock, deadline, [&] { return m_running.empty(); });
    for (auto& [id, live] : m_running) {
      live->cancel_for_shutdown = true;
      live->cancel = true;
    }
  }
  m_workers.reset();  // joins
}

std::atomic<int>* ThreadExecutor::StartLive(std::int64_t id) {
  std::lock_guard lock(m_mutex);
  std::shared_ptr<LiveJob>& live = m_running[id];
  live = std::make_shared<LiveJob>(id);
  return &live->threads;
}

QueueWorkers::RunEnd ThreadExecutor::RunTaken(std::int64_t id, int worker) {
  const std::shared_ptr<LiveJob> live = m_taken[static_cast<std::size_t>(worker)] = Live(id);
  m_log->info("worker {}: job {} starts", worker, id);
  t_current_job = id;
  // Nothing may leave a worker: an exception there would end the daemon (std::terminate),
  // and the job with it at every start.
  QueueWorkers::RunEnd end = QueueWorkers::RunEnd::kDone;  // its cores go to the others
  try {
    Run(id, live);
  } catch (const StorageFull& e) {
    RequeueForStorage(id, live, e);
    end = QueueWorkers::RunEnd::kRequeued;
  } catch (const std::exception& e) {
    FailAfterError(id, live, e.what());
  } catch (...) {
    FailAfterError(id, live, "an unknown error");
  }
  t_current_job = 0;
  return end;
}

void ThreadExecutor::EndTaken(std::int64_t id, int worker) {
  std::shared_ptr<LiveJob> live = std::move(m_taken[static_cast<std::size_t>(worker)]);
  {
    std::lock_guard lock(m_mutex);
    // (a requeued job may have been handed to another worker already, with a new LiveJob)
    if (auto it = m_running.find(id); it != m_running.end() && it->second == live)
      m_running.erase(it);
  }
  m_ended.notify_all();
}

void ThreadExecutor::FailAfterError(std::int64_t id, const std::shared_ptr<LiveJob>& live,
                                    const std::string& what) {
  const std::string error = "the server failed while running this job: " + what;
  m_log->error("job {}: {}", id, error);
  try {
    m_store.FinishJob(id, JobState::kFailed, error, {});
  } catch (const std::exception& e) {
    // The database says it still runs; the next start counts it as interrupted.
    m_log->error("job {}: could not record the failure: {}", id, e.what());
  }
  live->End(JobState::kFailed);
}

void ThreadExecutor::Run(std::int64_t id, const std::shared_ptr<LiveJob>& live) {
  const std::optional<JobRecord> job = m_store.GetJob(id);
  if (!job) {
    live->End(JobState::kFailed);
    return;
  }
  const auto started = std::chrono::steady_clock::now();
  const std::string started_at = report::UtcNow();
  const bool needs_bed = !job->bed_hash.empty() && !m_beds.Contains(job->bed_hash);
  const JobState first_state = needs_bed ? JobState::kPreparingBed : JobState::kRunning;
  m_store.MarkStarted(id, first_state, m_options.host, kVersion);
  FaultPoint("kill-at-job-start");  // a job that crashes the daemon (the poison-job test)
  live->SetState(first_state);
  StoreRecorder recorder(m_store, id, *live,
                         static_cast<std::size_t>(m_store.options().chunk_samples));
  try {
    const Scene scene = SceneOfJob(m_store, *job);
    JobControl control;
    control.context = {job->command_line, m_options.host, started_at, "", 0, {}};
    control.steering.cancel = &live->cancel;
    control.steering.threads = &live->threads;
    // One fraction over the whole job: the bed stages and the impact by their predicted time.
    std::vector<std::string> cached;
    const ResourceEstimate estimate = EstimateResources(scene);
    for (const StageEstimate& stage : estimate.stages)
      if (m_beds.Contains(stage.hash)) cached.push_back(stage.hash);
    WholeJobProgress whole(estimate, cached);
    control.on_bed_progress = [&](const BedProgress& p) {
      live->SetProgress("bed: " + p.stage, whole.WhileBed(p), p.t_s, 0);
    };
    control.on_bed_ready = [&](const World&) {
      if (first_state == JobState::kRunning) return;
      m_store.SetState(id, JobState::kRunning);
      live->SetState(JobState::kRunning);
    };
    control.steering.on_progress = [&](const ImpactProgress& p) {
      live->SetProgress("impact", whole.WhileImpact(p), p.t_s, p.steps);
    };
    control.steering.progress_every_steps = kProgressEverySteps;
    const ImpactSummary summary = RunJob(scene, m_beds, control, recorder);
    live->End(JobState::kDone);
    m_log->info("job {}: done in {:.1f} s: P = {:.5g} N, lambda = {:.3f}", id,
                std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count(),
                summary.peaks.p_N, summary.lambda);
  } catch (const StorageFull&) {
    throw;  // not the job's fault: RunTaken puts it back in the queue
  } catch (const Cancelled&) {
    if (live->cancel_for_shutdown) {
      const std::string note = "interrupted by a daemon shutdown; it runs again from the start";
      m_store.SetState(id, JobState::kQueued, note);
      m_store.LogEvent(id, note);
      live->End(JobState::kQueued);
      m_log->warn("job {}: {}", id, note);
    } else {
      m_store.FinishJob(id, JobState::kCancelled, "cancelled while running", recorder.Unfinished());
      live->End(JobState::kCancelled);
      m_log->info("job {}: cancelled while running", id);
    }
  } catch (const std::exception& e) {
    // A bad scene (it was checked at submission, so only a changed engine gets here), a run
    // that became unstable, or a bed that would not settle: the job fails with the reason.
    m_store.FinishJob(id, JobState::kFailed, e.what(), recorder.Unfinished());
    live->End(JobState::kFailed);
    m_log->error("job {}: failed: {}", id, e.what());
  }
}

void ThreadExecutor::RequeueForStorage(std::int64_t id, const std::shared_ptr<LiveJob>& live,
                                       const StorageFull& error) {
  const std::string note = "the server's disk is full; the job waits and runs again from the start";
  m_log->error("job {}: {} (in {} s): {}", id, note, m_options.storage_retry.count(), error.what());
  try {
    m_store.SetState(id, JobState::kQueued, note);
    m_store.LogEvent(id, note);
  } catch (const SqliteError& e) {
    // The database still says running; the next start of the daemon requeues such jobs too.
    m_log->error("job {}: could not record the requeue: {}", id, e.what());
  }
  live->End(JobState::kQueued);
  m_queue.PauseUntil(std::chrono::steady_clock::now() + m_options.storage_retry);
  m_queue.Requeue(id);
}

}  // namespace dembuf::server
