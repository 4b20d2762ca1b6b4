// The Slurm executor: every job runs as a job of the lab's Slurm cluster, `dembuf run` on a
// node, in a folder under work_dir that every node sees. The daemon stays the front: it
// submits, follows and records; Slurm places, queues and accounts.
//
//   work_dir/beds/                      the bed cache every job reads and fills
//   work_dir/jobs/<daemon>-<job>/       scene.toml, bed-file (a bed file sent with the job),
//                                       out/ (the run's files), samples.bin (the force
//                                       samples as they come), slurm.log
//   work_dir/jobs/<daemon>-array-<job>/ task-<i>.log: the logs of a job array's tasks (its
//                                       first dembuf job's id names it)
//   work_dir/bed-jobs/<hash>/           a bed preparation's scene.toml, bed-file, slurm.log
//
// The daemon owns work_dir (owned_files.h): it must be the daemon's account's and closed to
// others, every name in it is one the daemon makes, and what a node leaves is read without
// following links and within bounds. A run's result is taken only with the random nonce the
// daemon gave that job (DEMBUF_RESULT_NONCE, in sbatch's environment, which `dembuf run` writes
// into summary.json and failure.json): a file another account or an earlier daemon left is not.
//
// A bed is prepared once, by a job of its own (the source bed first when it has one), and the
// jobs that need it wait for it with --dependency=afterok. The run's own files are the truth
// about its end (summary.json: done, failure.json: failed); without them Slurm's state says
// why it ended (TIMEOUT, OUT_OF_MEMORY, NODE_FAIL, CANCELLED). Slurm job ids are stored with
// the jobs, and jobs are named dembuf-<daemon id>-<job id>, so that a restarted daemon takes
// up what runs instead of submitting it again, and never mistakes another job for its own.
//
// A sweep's jobs go as one job array (dembuf-<daemon id>-array-<first job id>), a task per
// job: task i runs job first + i, in that job's own folder; the array waits for every bed
// its tasks need, and runs at most slurm.array_limit tasks at once. Every Slurm job carries
// its dembuf user: in its comment, in its account (slurm.accounts) and wckey if configured.
#pragma once

#include <spdlog/logger.h>

#include <chrono>
#include <condition_variable>
#include <filesystem>
#include <map>
#include <mutex>
#include <thread>

#include "dembuf/study/scene/scene.h"
#include "jobs/executor.h"
#include "jobs/slurm.h"
#include "store/owned_files.h"

namespace dembuf::server {

struct SlurmExecutorOptions {
  slurm::Settings slurm;
  int queue_limit = 1000;
  std::string dembuf;                           ///< the dembuf program the nodes run (resolved)
  std::uint64_t max_result_bytes = UINT64_MAX;  ///< a job's result files read back, at most
};

class SlurmExecutor final : public Executor {
 public:
  /// Opens (or makes, 0700) work_dir and its folders; throws OwnershipError when they are not
  /// the daemon's alone (before the daemon serves anything).
  SlurmExecutor(Store& store, SlurmExecutorOptions options, std::shared_ptr<spdlog::logger> log);
  ~SlurmExecutor() override;

  void Start() override;
  void Admit(std::size_t count, const std::function<std::vector<JobRecord>()>& add) override;
  bool Cancel(std::int64_t id) override;
  std::shared_ptr<LiveJob> Live(std::int64_t id) override;
  int queued() const override;
  int running() const override;
  ExecutorInfo info() const override {
    return {"slurm", 0, m_options.slurm.cpus_per_job, m_options.queue_limit};
  }
  /// Stops following the cluster; its jobs go on, and the next start takes them up.
  void AddBed(const PreparedBed& bed) override;
  void Shutdown(std::chrono::seconds grace) override;

 private:
  /// What a job's run may write and how long it runs, by its scene's estimate (a node may
  /// write more: it is not taken).
  struct JobBounds {
    double expected_end_s = 0.0;         ///< simulated time at which the run ends at the latest
    std::uint64_t samples_max = 0;       ///< the most samples its run may write
    std::uint64_t result_bytes_max = 0;  ///< the most bytes of result files taken from its node
  };
  /// What the daemon follows of a running job.
  struct Followed {
    std::shared_ptr<LiveJob> live;
    JobBounds bounds;
  };
  /// A job that could not be submitted for now (NoteNotSubmitted): when to try it again.
  struct NotSubmitted {
    std::chrono::steady_clock::time_point next;
    double wait_s = 0.0;  // doubles at each failure, from slurm.poll_s up to 300 s
  };

  void Loop();
  void Tick();
  /// Jobs a daemon before this one submitted: found by name in Slurm, or by their results.
  void Adopt();
  void SubmitQueued();
  /// Takes `job` up in its Slurm job or array task among `in_slurm` (found by name), if there
  /// is one at least `least` alive (the newest: ChooseCopy), and cancels its other live copies;
  /// whether it was.
  bool TakeUpFound(const JobRecord& job, const std::vector<slurm::JobStatus>& in_slurm,
                   slurm::Liveness least);
  /// Notes on every queued job not yet in Slurm that Slurm cannot be reached, and why;
  /// whether any job's note changed.
  bool NoteWaitingForSlurm(std::string what);
  /// NoteWaitingForSlurm for a pass that meets an unreachable Slurm at `job_id`, logged when
  /// a note changed.
  void WaitForSlurm(std::int64_t job_id, const std::string& what);
  /// Whether a folder the daemon could not make or open is one it may not use (a file, a
  /// link, another account's folder): its jobs fail; other errors of the system pass.
  static bool NotOursToUse(const OwnershipError& e);
  /// Notes on `jobs` that they could not be submitted for now, and why (a full disk): they
  /// stay queued for the next poll, and the queue goes on past them.
  void NoteNotSubmitted(const std::vector<JobRecord>& jobs, std::string what);
  void Submit(const JobRecord& job);
  /// Submits a sweep's jobs (ids rising from jobs[0]'s) as one job array; returns the ids
  /// submitted (a job whose scene cannot run, or whose bed Slurm refused, fails alone).
  std::vector<std::int64_t> SubmitArray(const std::vector<JobRecord>& jobs);
  /// Fails a job whose stored scene this daemon cannot run (SceneError), with the reason.
  void FailUnrunnable(const JobRecord& job, const std::string& why);
  /// The queued jobs submitted with `first`: it alone, or with the rest of its sweep's not yet
  /// submitted, as one array (at most slurm.array_tasks_max, ids from first's on).
  std::vector<JobRecord> SubmittedWith(const JobRecord& first,
                                       const std::vector<JobRecord>& unfinished) const;
  /// The Slurm job that prepares the job's bed (and its source before it), submitting it if
  /// none has it: 0 when the bed is ready.
  std::int64_t BedDependency(const JobRecord& job, const Scene& scene);
  /// `dembuf run`'s arguments for a job whose folder is `folder`.
  std::vector<std::string> RunArgs(const std::string& folder) const;
  /// The Slurm job preparing this bed, submitting it if none has it: 0 when the bed is ready.
  std::int64_t BedJob(const std::string& hash, const std::string& stage, const JobRecord& job,
                      const Scene& scene, std::int64_t after);
  void PollBeds(const std::map<slurm::JobKey, slurm::JobStatus>& status);
  void PollJobs(const std::map<slurm::JobKey, slurm::JobStatus>& status);
  /// Puts an array's task back in the queue when Slurm ended the array because another
  /// task's bed failed; whether it did.
  bool ArrayEndedForAnotherBed(const JobRecord& job, const slurm::JobStatus& status);
  /// A job whose run ended: its results from its folder, or Slurm's reason.
  void Finish(const JobRecord& job, const std::optional<slurm::JobStatus>& status);
  void FailDependents(const std::string& bed_hash, const std::string& why);
  /// Cancels the bed jobs that no job waits for any more.
  void CancelUnneededBeds();
  /// Reads the job's new samples from samples.bin into its LiveJob, storing full chunks; false
  /// (nothing more taken) once the file holds more samples than its run may write.
  bool Follow(std::int64_t id, Followed& followed);
  /// The job's bounds, from its scene read once a call (a scene the estimate cannot take: no
  /// expected end, and the daemon's own limits; the job fails as it ends).
  JobBounds BoundsOf(const JobRecord& job);
  Followed& StartFollowing(const JobRecord& job);

  /// A job's folder, made when `make` is set (else OwnershipError when it is not there).
  OwnedFolder JobFolder(std::int64_t id, bool make) const;
  /// The folder of the job array whose first job is `base` (its tasks' logs).
  OwnedFolder ArrayFolder(std::int64_t base, bool make) const;
  std::string JobName(std::int64_t id) const;
  std::string ArrayName(std::int64_t base) const;
  /// The name of the Slurm job that runs the job: its own, or its array's.
  std::string SlurmName(const JobRecord& job) const;
  std::string BedJobName(const std::string& hash) const;
  bool BedReady(const std::string& hash) const;
  /// The last line the run printed that says what went wrong, from its Slurm log.
  std::string LastError(const JobRecord& job) const;
  static std::string LastError(const OwnedFolder& folder, const std::string& log = "slurm.log");
  /// A Slurm job of `dembuf dembuf_args...` in `folder`, where it writes the job's scene (and
  /// its bed file), after job `after` (0: none): its memory and time from the settings, else
  /// from the scene's estimate (`bed_only`: the estimate of preparing its bed; else of its
  /// impact alone), and its job's user in Slurm's accounting. `nonce`, when given, goes to
  /// the job as DEMBUF_RESULT_NONCE (sbatch's environment).
  slurm::Submission NewSubmission(const std::string& name, const OwnedFolder& folder,
                                  const JobRecord& job, const Scene& scene, bool bed_only,
                                  std::int64_t after, const std::vector<std::string>& dembuf_args,
                                  const std::string& nonce = "") const;

  Store& m_store;
  SlurmExecutorOptions m_options;
  std::shared_ptr<spdlog::logger> m_log;
  slurm::Client m_slurm;
  OwnedFolder m_work;      ///< work_dir
  OwnedFolder m_beds;      ///< work_dir/beds
  OwnedFolder m_jobs;      ///< work_dir/jobs
  OwnedFolder m_bed_jobs;  ///< work_dir/bed-jobs
  std::string m_daemon_id;

  // m_work_mutex: one of the loop's passes, or a cancel, at a time. m_mutex: the followed
  // jobs (watchers read them while a pass runs). Taken in that order.
  std::mutex m_work_mutex;
  std::map<std::int64_t, NotSubmitted> m_not_submitted;  ///< under m_work_mutex
  mutable std::mutex m_mutex;
  std::condition_variable m_wake;
  std::map<std::int64_t, Followed> m_followed;
  bool m_stopping = false;
  bool m_woken = false;
  std::mutex m_admit_mutex;
  std::jthread m_loop;
};

}  // namespace dembuf::server
