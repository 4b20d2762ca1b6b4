// Slurm through its command-line tools (sbatch, squeue, scontrol, scancel): stable across
// versions, nothing to link, and they work wherever the daemon's user may submit jobs. What
// they print is parsed as untrusted text: a line that does not parse is left out.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace dembuf::server::slurm {

/// A Slurm command failed (not found, refused the job, timed out); the message has its output.
class SlurmError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Whether a Slurm command's failure says the cluster could not be reached (no controller, no
/// configuration, the command missing or silent), so that a job waits for it, rather than
/// that the cluster refused the job (a partition, memory or time it does not have), which
/// fails the job. sbatch says "Batch job submission failed" in both cases.
bool SlurmUnreachable(const std::string& error);

/// A job as squeue or scontrol describes it.
struct JobStatus {
  std::int64_t id = 0;  ///< the job's id; a job array's own id for each of its tasks
  int task = -1;        ///< the task's index in its job array; -1: not an array's task
  std::string name;
  std::string state;   ///< PENDING, RUNNING, COMPLETED, FAILED, CANCELLED, TIMEOUT, ...
  std::string reason;  ///< why it waits or ended (Dependency, TimeLimit, None, ...)
  std::string node;    ///< where it runs ("" while pending)
};

/// Whether a job in this state will not run again (COMPLETED, FAILED, CANCELLED, TIMEOUT,
/// OUT_OF_MEMORY, NODE_FAIL, PREEMPTED, BOOT_FAIL, DEADLINE).
bool IsFinalState(std::string_view state);

/// How far a job is from its end: kMayRun (pending, running, suspended: it may still do its
/// work), kEnding (COMPLETING: its processes are being ended, as a job's cancelled a moment
/// ago are; or pending on a dependency that can never be met), kEnded (a final state).
enum class Liveness { kEnded, kEnding, kMayRun };
Liveness LivenessOf(const JobStatus& job);

/// Of the jobs `matches` accepts that are at least `least` alive, the one to follow as a job
/// whose id the daemon lost: the newest (the highest id; Slurm numbers jobs in the order they
/// come), which is the last sbatch's, the one whose result the job's nonce accepts. nullptr
/// when there is none.
const JobStatus* ChooseCopy(const std::vector<JobStatus>& jobs,
                            const std::function<bool(const JobStatus&)>& matches, Liveness least);

/// A job of Slurm's as the daemon names it: the job's id and its task in a job array (-1:
/// not an array's task). A job array's tasks share its id.
using JobKey = std::pair<std::int64_t, int>;

/// The most copies OtherLiveCopies names: a squeue listing more is not a cluster's honest answer.
inline constexpr std::size_t kMaxOtherCopies = 16;
/// The jobs `matches` accepts that may still run, but `chosen`: each named once (squeue may
/// print a line twice), at most kMaxOtherCopies of them.
std::vector<JobKey> OtherLiveCopies(const std::vector<JobStatus>& jobs,
                                    const std::function<bool(const JobStatus&)>& matches,
                                    const JobStatus& chosen);

/// squeue's output format: the job's (or its array's) id, the array task ("N/A" for none),
/// name, state, reason, node.
inline constexpr const char* kSqueueFormat = "%F|%K|%j|%T|%r|%N";
/// The lines of `squeue -h -r -o kSqueueFormat` (-r: an array's tasks one per line).
std::vector<JobStatus> ParseSqueue(std::string_view output);
/// One line of `scontrol show job -o` (JobId=.. ArrayJobId=.. ArrayTaskId=.. JobName=..
/// JobState=.. Reason=..); an array's tasks that still wait together ("ArrayTaskId=3-9%2")
/// are each one status. Nothing when the line does not parse.
std::vector<JobStatus> ParseScontrolJob(std::string_view line);
/// An array's task indexes as sbatch's --array takes them: "0-3,7,9-10".
std::string FormatArrayIndexes(std::vector<int> indexes);
/// The indexes of such a list (a "%N" limit after it ignored); nothing when it is not one or
/// names more than `most` indexes.
std::optional<std::vector<int>> ParseArrayIndexes(std::string_view text, std::size_t most = 100000);
/// The job id sbatch --parsable prints ("123" or "123;cluster").
std::optional<std::int64_t> ParseSbatchId(std::string_view output);

/// A Slurm time limit in seconds: "MM", "MM:SS", "HH:MM:SS", "D-HH", "D-HH:MM", "D-HH:MM:SS".
std::optional<int> ParseTimeLimit(std::string_view text);
/// Seconds as Slurm's "MM:SS" (minutes may pass 59).
std::string FormatTimeLimit(int seconds);

/// What the daemon asks of the cluster for every job (dembufd's [slurm] settings).
struct Settings {
  std::string partition;  ///< "" for the cluster's default
  std::string account;    ///< "" for the user's default
  int cpus_per_job = 1;
  int mem_per_job_mb = 0;               ///< 0: from the job's estimate
  std::string time_limit;               ///< Slurm's format; "" from the job's estimate
  std::vector<std::string> extra_args;  ///< more sbatch arguments, one word each
  std::string work_dir;                 ///< a folder every node sees: job folders, bed cache
  std::string dembuf;   ///< the dembuf program on the nodes; "" for the one beside dembufd
  double poll_s = 2.0;  ///< how often squeue is asked
  /// A sweep's jobs go to Slurm as job arrays of at most this many tasks (1: a job each).
  int array_tasks_max = 1000;
  int array_limit = 0;  ///< an array's tasks that run at once, at most (0: no limit)
  /// Slurm's account of each dembuf user's jobs (one not named: `account`).
  std::map<std::string, std::string> accounts;
  bool wckey = false;          ///< each job's wckey is its dembuf user's name
  int command_timeout_s = 60;  ///< a Slurm command that takes longer has failed
  bool operator==(const Settings&) const = default;
};

/// In an array's command, where each task puts its dembuf job's id (the array's first job id
/// plus the task's index): "WORK_DIR/jobs/d-{job}/scene.toml".
inline constexpr std::string_view kTaskJobId = "{job}";

/// One job to submit, or one job array.
struct Submission {
  std::string name;    ///< dembuf-<daemon id>-<job id>, or -bed-<hash>
  std::string folder;  ///< its working folder (--chdir)
  std::string log;     ///< its stdout and stderr (-o)
  int cpus = 1;
  int mem_mb = 0;                      ///< 0: the cluster's default
  int time_s = 0;                      ///< 0: the partition's default
  std::vector<std::int64_t> after_ok;  ///< jobs that must end well first
  std::vector<std::string> command;    ///< the program and its arguments
  /// A job array's task indexes ([] for one job): task i runs the command with kTaskJobId as
  /// array_base + i.
  std::vector<int> array_tasks;
  std::int64_t array_base = 0;
  int array_limit = 0;  ///< tasks that run at once, at most (0: as many as Slurm places)
  std::string account;  ///< "" for the settings' account
  std::string wckey;    ///< "" for none
  std::string comment;  ///< what the job's record says (who asked for it)
  /// Variables the job gets (names of [A-Z_], made by the daemon): in sbatch's environment,
  /// which sbatch hands to the job (--export=ALL) and only the daemon's account may read, not
  /// on sbatch's command line, which every account on the machine may.
  std::vector<std::pair<std::string, std::string>> environment;
};

/// The sbatch arguments of a submission: every value one argument, and the command a single
/// shell word each (sbatch --wrap runs a shell line: each word is quoted; in an array's,
/// kTaskJobId becomes the task's job id, computed by the shell from SLURM_ARRAY_TASK_ID).
std::vector<std::string> SbatchArgs(const Settings& settings, const Submission& job);
/// The "NAME=value" entries sbatch runs with for a submission (its `environment`). Throws
/// SlurmError for a name that is not one of [A-Z_].
std::vector<std::string> SubmitEnvironment(const Submission& job);

/// Runs the commands. Thread-compatible (no state besides the settings).
class Client {
 public:
  explicit Client(Settings settings) : m_settings(std::move(settings)) {}

  /// Submits; returns the Slurm job id. Throws SlurmError with sbatch's words.
  std::int64_t Submit(const Submission& job);
  /// The state of these jobs and of their arrays' tasks: squeue first; the jobs it does not
  /// list (finished long ago, or unknown) from scontrol. A job neither knows is absent.
  /// Throws SlurmError when squeue itself cannot be run.
  std::map<JobKey, JobStatus> Query(const std::vector<std::int64_t>& ids);
  /// Jobs whose name starts with `prefix` (the daemon's own: to re-adopt after a restart).
  std::vector<JobStatus> FindByNamePrefix(const std::string& prefix);
  /// Cancels a job, or one task of an array; a job already ended is no error.
  void Cancel(std::int64_t id, int task = -1);

  const Settings& settings() const { return m_settings; }

 private:
  std::string Run(const std::vector<std::string>& args, bool check = true,
                  const std::vector<std::string>& environment = {});

  Settings m_settings;
};

}  // namespace dembuf::server::slurm
