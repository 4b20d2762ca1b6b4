#include "jobs/slurm_executor.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <sstream>

#include "access/auth.h"
#include "dembuf/study/bed/bed.h"
#include "dembuf/study/files/provenance.h"
#include "dembuf/study/files/run_output.h"
#include "dembuf/study/files/snapshot_report.h"
#include "dembuf/study/run/resource_estimate.h"
#include "dembuf/study/scene/errors.h"
#include "dembuf/study/scene/scene_fields.h"
#include "dembuf/study/text/text_limits.h"
#include "dembuf/study/version.h"
#include "jobs/job_scene.h"

namespace dembuf::server {

namespace fs = std::filesystem;

namespace {

// The start of a queued job's note while Slurm cannot be reached (cleared once submitted).
const std::string kWaitingForSlurm = "waiting: cannot reach Slurm (";
// The same while its folder or files cannot be made for now (a full disk).
const std::string kWaitingToSubmit = "waiting: cannot be submitted for now (";

// The name a bed file sent with a job has in its folder on the nodes: one the daemon makes,
// whatever its user called it (the format is told from the file itself).
constexpr const char* kNodeBedFile = "bed-file";

// A run's summary.json or failure.json, as a node left it: a regular file of the daemon's
// (no link followed), bounded (a summary is a few kB), no deeper than kMaxJsonDepth, a JSON
// object, and written by the run this daemon started: it carries the nonce the daemon gave
// the job, which is taken out. Nothing when the file is absent; a std::runtime_error saying
// what is wrong otherwise.
std::optional<nlohmann::json> ReadRunJson(const OwnedFolder& out, const std::string& name,
                                          const std::string& nonce) {
  const std::optional<std::string> text = out.Read(name, 4 << 20);
  if (!text) return std::nullopt;
  nlohmann::json json = ParseBoundedJson(*text, name);
  if (!json.is_object()) throw std::runtime_error(name + " is not a JSON object");
  const auto proof = json.find(report::kResultNonceKey);
  if (nonce.empty() || proof == json.end() || !proof->is_string() || *proof != nonce)
    throw std::runtime_error(name +
                             " was not written by the run this daemon started (it lacks "
                             "the nonce the daemon gave the job)");
  json.erase(proof);
  return json;
}

// Samples read from a run's stream in one pass at most: a run gone wild cannot make the
// daemon read much at once (3 MB; the rest comes in the next passes).
constexpr std::uint64_t kMaxSamplesPerRead = 1 << 16;
// Samples read at a job's end at most (a run writes its last ones between two looks).
constexpr std::uint64_t kMaxSamplesAtEnd = 1 << 20;

// Result files read back from a job's folder at most: a server job takes at most
// kMaxServerSnapshots snapshots of report::SnapshotFiles' files each and their .pvd,
// kMaxAnimationFrames frames and theirs, container.vtp, and the bare-plate series.
constexpr std::size_t kMaxResultFiles = report::kSnapshotFileCount * kMaxServerSnapshots + 1 +
                                        static_cast<std::size_t>(kMaxAnimationFrames) + 1 + 1 + 1;

// The whole samples of a job's samples.bin from sample `from` on, at most `most` of them (a
// sample written half is left for the next look).
std::vector<ImpactSample> ReadSamples(const OwnedFolder& folder, std::uint64_t from,
                                      std::uint64_t most) {
  std::string bytes = folder.ReadFrom("samples.bin", from * report::kPackedSampleBytes,
                                      most * report::kPackedSampleBytes);
  bytes.resize(bytes.size() - bytes.size() % report::kPackedSampleBytes);
  return report::UnpackSamples(bytes);
}

// Jobs in their owners' turns: each owner's first, then each one's second, ...: Slurm queues
// them in the order they come, so that one user's sweep does not go before another's job.
std::vector<JobRecord> InTurns(const std::vector<JobRecord>& jobs) {
  std::map<std::string, std::vector<const JobRecord*>> by_owner;
  std::vector<std::string> owners;  // in the order they first come
  for (const JobRecord& job : jobs) {
    std::vector<const JobRecord*>& mine = by_owner[job.owner];
    if (mine.empty()) owners.push_back(job.owner);
    mine.push_back(&job);
  }
  std::vector<JobRecord> turns;
  for (std::size_t round = 0; turns.size() < jobs.size(); ++round)
    for (const std::string& owner : owners)
      if (round < by_owner[owner].size()) turns.push_back(*by_owner[owner][round]);
  return turns;
}

// Why Slurm ended a job that left no result, in words, with Slurm's state name in them.
std::string SlurmReason(const std::optional<slurm::JobStatus>& status,
                        const std::string& slurm_job) {
  const std::string job = "Slurm job " + slurm_job;
  if (!status) return job + " is unknown to Slurm and left no result (its state was wiped?)";
  const std::string& state = status->state;
  if (state == "TIMEOUT") return job + " passed its time limit: TIMEOUT";
  if (state == "OUT_OF_MEMORY") return job + " passed its memory limit: OUT_OF_MEMORY";
  if (state == "NODE_FAIL") return job + " lost its node: NODE_FAIL";
  if (state == "CANCELLED")
    return job + " was cancelled outside dembuf (scancel, or an administrator): CANCELLED";
  if (state == "COMPLETED") return job + " ended without writing its result: COMPLETED";
  return job + " ended: " + state +
         (status->reason.empty() || status->reason == "None" ? "" : " (" + status->reason + ")");
}

// A job's Slurm job as Slurm writes it: "123", or "123_4" for task 4 of array 123.
std::string SlurmJobText(const JobRecord& job) {
  return std::to_string(job.slurm_id) +
         (job.slurm_task < 0 ? "" : "_" + std::to_string(job.slurm_task));
}

std::string ToLower(std::string text) {
  for (char& c : text) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return text;
}

std::string BedWords(const std::string& stage) {
  return stage == "source" ? "the source bed" : "the bed";
}

}  // namespace

SlurmExecutor::SlurmExecutor(Store& store, SlurmExecutorOptions options,
                             std::shared_ptr<spdlog::logger> log)
    : m_store(store),
      m_options(std::move(options)),
      m_log(std::move(log)),
      m_slurm(m_options.slurm),
      m_work(OwnedFolder::Open(fs::absolute(m_options.slurm.work_dir), "slurm.work_dir", true)),
      m_beds(m_work.Folder("beds", true)),
      m_jobs(m_work.Folder("jobs", true)),
      m_bed_jobs(m_work.Folder("bed-jobs", true)) {}

SlurmExecutor::~SlurmExecutor() {
  Shutdown(std::chrono::seconds(0));
}

void SlurmExecutor::Start() {
  m_daemon_id = m_store.DaemonId();
  Adopt();
  m_log->info("jobs run on Slurm as dembuf-{}-<job id>, {} CPUs each, in {}; nodes run {}",
              m_daemon_id, m_options.slurm.cpus_per_job, m_work.path().string(), m_options.dembuf);
  m_loop = std::jthread([this] { Loop(); });
}

void SlurmExecutor::Adopt() {
  std::vector<slurm::JobStatus> in_slurm;
  try {
    in_slurm = m_slurm.FindByNamePrefix("dembuf-" + m_daemon_id + "-");
  } catch (const slurm::SlurmError& e) {
    // Started degraded: the daemon serves, and jobs wait queued, saying why, until Slurm
    // answers.
    m_log->error(
        "cannot ask Slurm for this daemon's jobs: {}; serving anyway, jobs stay queued until "
        "Slurm answers",
        e.what());
    NoteWaitingForSlurm(e.what());
  }
  for (const JobRecord& job : m_store.UnfinishedJobs()) {
    if (job.slurm_id != 0) {
      m_log->info("job {}: taken up again in Slurm job {}", job.id, job.slurm_id);
      continue;
    }
    // Submitted by a daemon that died before it could store the Slurm id?
    if (TakeUpFound(job, in_slurm, slurm::Liveness::kEnded)) continue;
    if (job.state != JobState::kQueued) {
      // Left running by the thread executor before a change of executor.
      const std::string note = "interrupted: the daemon stopped while this job ran; it runs again";
      m_store.SetState(job.id, JobState::kQueued, note);
      m_store.LogEvent(job.id, note);
    }
  }
}

bool SlurmExecutor::TakeUpFound(const JobRecord& job, const std::vector<slurm::JobStatus>& in_slurm,
                                slurm::Liveness least) {
  // Its own Slurm job, or a task of an array named by its first job (task i of array b runs
  // job b + i).
  const auto is_this_job = [&](const slurm::JobStatus& s) {
    return s.task < 0 ? s.name == JobName(job.id) : s.name == ArrayName(job.id - s.task);
  };
  const slurm::JobStatus* found = slurm::ChooseCopy(in_slurm, is_this_job, least);
  if (!found) return false;
  const std::int64_t base = found->task < 0 ? -1 : job.id - found->task;
  m_store.SetSlurmId({job.id}, found->id, base);
  m_log->warn("job {}: found in Slurm as job {}; taken up, not submitted again", job.id, found->id);
  // Another copy (the job sent again) would run into the same folder, unwatched.
  for (const auto& [id, task] : slurm::OtherLiveCopies(in_slurm, is_this_job, *found)) {
    try {
      m_slurm.Cancel(id, task);
      m_log->warn("job {}: its other Slurm job {} cancelled: one run to a folder", job.id, id);
    } catch (const slurm::SlurmError& e) {
      m_log->error("job {}: cannot cancel its other Slurm job {}: {}", job.id, id, e.what());
    }
  }
  return true;
}

void SlurmExecutor::Admit(std::size_t count, const std::function<std::vector<JobRecord>()>& add) {
  std::lock_guard admit(m_admit_mutex);
  {
    std::lock_guard lock(m_mutex);
    if (m_stopping) throw QueueFull("the daemon is shutting down");
  }
  CheckQueueRoom(static_cast<std::size_t>(queued()), count, m_options.queue_limit);
  add();
  {
    std::lock_guard lock(m_mutex);
    m_woken = true;
  }
  m_wake.notify_all();
}

bool SlurmExecutor::Cancel(std::int64_t id) {
  std::lock_guard work(m_work_mutex);  // not while a pass submits it
  const std::optional<JobRecord> job = m_store.GetJob(id);
  if (!job || IsFinal(job->state)) return false;
  m_store.RequestCancel(id);
  if (job->slurm_id == 0) {
    m_store.FinishJob(id, JobState::kCancelled, "cancelled while queued", {});
    m_log->info("job {}: cancelled while queued", id);
    return true;
  }
  // It ends when Slurm says so (the next pass records it): the run gets SIGTERM first.
  try {
    m_slurm.Cancel(job->slurm_id, job->slurm_task);
  } catch (const slurm::SlurmError& e) {
    m_log->error("job {}: scancel {}: {}", id, job->slurm_id, e.what());
    throw std::runtime_error("Slurm did not take the cancel: " + std::string(e.what()));
  }
  m_log->info("job {}: cancel requested (scancel {})", id, job->slurm_id);
  {
    std::lock_guard lock(m_mutex);
    m_woken = true;
  }
  m_wake.notify_all();
  return true;
}

std::shared_ptr<LiveJob> SlurmExecutor::Live(std::int64_t id) {
  std::lock_guard lock(m_mutex);
  const auto it = m_followed.find(id);
  return it == m_followed.end() ? nullptr : it->second.live;
}

int SlurmExecutor::queued() const {
  return m_store.CountQueued();
}

int SlurmExecutor::running() const {
  std::lock_guard lock(m_mutex);
  return static_cast<int>(m_followed.size());
}

void SlurmExecutor::Shutdown(std::chrono::seconds) {
  {
    std::lock_guard lock(m_mutex);
    if (m_stopping && !m_loop.joinable()) return;
    m_stopping = true;
  }
  m_wake.notify_all();
  if (m_loop.joinable()) m_loop.join();
  std::lock_guard lock(m_mutex);
  if (!m_followed.empty())
    m_log->info("{} jobs go on running in Slurm; the next start takes them up", m_followed.size());
  // Watchers see the stream end; the job itself is not ended.
  for (auto& [id, followed] : m_followed) followed.live->End(JobState::kRunning);
  m_followed.clear();
}

void SlurmExecutor::Loop() {
  const auto interval = std::chrono::milliseconds(
      static_cast<std::int64_t>(std::max(0.1, m_options.slurm.poll_s) * 1000));
  for (;;) {
    try {
      Tick();
    } catch (const std::exception& e) {
      // The database or Slurm failed for now: the next pass tries again.
      m_log->error("following the cluster: {}", e.what());
    }
    std::unique_lock lock(m_mutex);
    m_wake.wait_for(lock, interval, [&] { return m_stopping || m_woken; });
    m_woken = false;
    if (m_stopping) return;
  }
}

void SlurmExecutor::Tick() {
  std::lock_guard work(m_work_mutex);
  std::set<std::int64_t> ids;  // (an array's tasks share its id)
  for (const SlurmBedJob& bed : m_store.SlurmBedsInState("submitted")) ids.insert(bed.slurm_id);
  for (const JobRecord& job : m_store.UnfinishedJobs())
    if (job.slurm_id != 0) ids.insert(job.slurm_id);
  // Slurm first, then the folders: a run whose files are not there yet when Slurm says it
  // ended has really ended without them.
  const std::map<slurm::JobKey, slurm::JobStatus> status = m_slurm.Query({ids.begin(), ids.end()});
  PollBeds(status);
  PollJobs(status);
  CancelUnneededBeds();
  // After the look: a bed found failed is not taken as a dependency of a new job.
  SubmitQueued();
}

void SlurmExecutor::CancelUnneededBeds() {
  std::set<std::string> needed;
  for (const JobRecord& job : m_store.UnfinishedJobs()) {
    if (job.cancel_requested) continue;
    needed.insert(job.bed_hash);
    needed.insert(job.source_hash);
  }
  // Every job that waited for the bed was cancelled (a cancelled sweep): its cores go back.
  for (SlurmBedJob bed : m_store.SlurmBedsInState("submitted")) {
    if (needed.count(bed.hash)) continue;
    m_slurm.Cancel(bed.slurm_id);
    bed.state = "cancelled";
    bed.error = "no job needs it any more";
    m_store.PutSlurmBed(bed);
    m_log->info("{} {}: Slurm job {} cancelled, no job needs it any more", BedWords(bed.stage),
                bed.hash, bed.slurm_id);
  }
  // A bed whose sbatch printed no id may be queued all the same: found by its name, it is
  // cancelled too, or it would prepare a bed for nobody. Marked cancelled only once Slurm lists
  // no live copy, so a scancel that failed is met again. (A job Slurm shows only after that is
  // not looked for again here; the next job needing the bed takes it up: BedJob.)
  std::optional<std::vector<slurm::JobStatus>> in_slurm;  // asked once a pass, if needed
  for (SlurmBedJob bed : m_store.SlurmBedsInState("submitting")) {
    if (needed.count(bed.hash)) continue;
    const std::string name = BedJobName(bed.hash);
    bool live = false;
    try {
      if (!in_slurm) in_slurm = m_slurm.FindByNamePrefix(BedJobName(""));
      for (const slurm::JobStatus& s : *in_slurm)
        if (s.name == name && !slurm::IsFinalState(s.state)) {
          m_slurm.Cancel(s.id);
          live = true;
          m_log->info("{} {}: Slurm job {} cancelled, no job needs it any more",
                      BedWords(bed.stage), bed.hash, s.id);
        }
    } catch (const slurm::SlurmError&) {
      return;  // Slurm does not answer: the next pass looks again
    }
    if (live) continue;
    bed.state = "cancelled";
    bed.error = "no job needs it any more";
    m_store.PutSlurmBed(bed);
    m_log->info("{} {}: no job needs it any more, and Slurm lists no job preparing it",
                BedWords(bed.stage), bed.hash);
  }
}

std::string SlurmExecutor::JobName(std::int64_t id) const {
  return "dembuf-" + m_daemon_id + "-" + std::to_string(id);
}

std::string SlurmExecutor::ArrayName(std::int64_t base) const {
  return "dembuf-" + m_daemon_id + "-array-" + std::to_string(base);
}

std::string SlurmExecutor::SlurmName(const JobRecord& job) const {
  return job.slurm_task < 0 ? JobName(job.id) : ArrayName(job.id - job.slurm_task);
}

std::string SlurmExecutor::BedJobName(const std::string& hash) const {
  return "dembuf-" + m_daemon_id + "-bed-" + hash;
}

OwnedFolder SlurmExecutor::JobFolder(std::int64_t id, bool make) const {
  return m_jobs.Folder(m_daemon_id + "-" + std::to_string(id), make);
}

OwnedFolder SlurmExecutor::ArrayFolder(std::int64_t base, bool make) const {
  return m_jobs.Folder(m_daemon_id + "-array-" + std::to_string(base), make);
}

bool SlurmExecutor::BedReady(const std::string& hash) const {
  return m_beds.Contains(hash + ".bed");
}

namespace {

// A job that waits to be submitted to Slurm.
bool Unsubmitted(const JobRecord& job) {
  return job.slurm_id == 0 && job.state == JobState::kQueued && !job.cancel_requested;
}

}  // namespace

std::vector<JobRecord> SlurmExecutor::SubmittedWith(
    const JobRecord& first, const std::vector<JobRecord>& unfinished) const {
  std::vector<JobRecord> jobs = {first};
  if (first.sweep_id == 0) return jobs;
  // Task i is job first + i: Slurm's index limit (MaxArraySize) bounds the ids' span.
  for (const JobRecord& job : unfinished)
    if (job.id > first.id && job.id - first.id < m_options.slurm.array_tasks_max &&
        job.sweep_id == first.sweep_id && job.owner == first.owner && Unsubmitted(job))
      jobs.push_back(job);
  std::sort(jobs.begin(), jobs.end(), [](const auto& a, const auto& b) { return a.id < b.id; });
  return jobs;
}

void SlurmExecutor::SubmitQueued() {
  const std::vector<JobRecord> unfinished = m_store.UnfinishedJobs();
  std::set<std::int64_t> submitted;                       // in an array, this pass
  std::optional<std::vector<slurm::JobStatus>> in_slurm;  // asked once a pass, if needed
  for (const JobRecord& job : InTurns(unfinished)) {
    if (!Unsubmitted(job) || submitted.count(job.id)) continue;
    if (const auto wait = m_not_submitted.find(job.id);
        wait != m_not_submitted.end() && std::chrono::steady_clock::now() < wait->second.next)
      continue;  // waiting for room (NoteNotSubmitted)
    {
      std::lock_guard lock(m_mutex);
      if (m_stopping) return;
    }
    // Tried before (its nonce is set just before sbatch): an sbatch that queued it but timed
    // out or printed no id it could be known by counts as unreachable, and submitting it
    // again queued a second run of it into the same folder at every poll. Found by name, it
    // is taken up instead.
    if (!job.result_nonce.empty()) {
      try {
        if (!in_slurm) in_slurm = m_slurm.FindByNamePrefix("dembuf-" + m_daemon_id + "-");
      } catch (const slurm::SlurmError& e) {
        WaitForSlurm(job.id, e.what());
        return;
      }
      if (TakeUpFound(job, *in_slurm, slurm::Liveness::kEnding)) continue;
    }
    // The rest of its sweep with it (jobs in turns: the sweep's first unsubmitted job).
    const std::vector<JobRecord> jobs = SubmittedWith(job, unfinished);
    for (const JobRecord& with : jobs) submitted.insert(with.id);
    try {
      std::vector<std::int64_t> sent = {job.id};
      if (jobs.size() == 1)
        Submit(job);
      else
        sent = SubmitArray(jobs);
      for (const JobRecord& with : jobs) {
        m_not_submitted.erase(with.id);
        if ((with.error.rfind(kWaitingForSlurm, 0) == 0 ||
             with.error.rfind(kWaitingToSubmit, 0) == 0) &&
            std::find(sent.begin(), sent.end(), with.id) != sent.end())
          m_store.SetState(with.id, JobState::kQueued);
      }
    } catch (const SceneError& e) {
      // A stored scene this daemon cannot run (one written by another version, a bed file
      // gone): the job fails with the reason, and the queue goes on past it.
      FailUnrunnable(job, e.what());
    } catch (const SqliteError&) {
      throw;  // the daemon's own store: no job's fault; the next pass tries again
    } catch (const StoreError&) {
      throw;
    } catch (const slurm::SlurmError& e) {
      const std::string what = e.what();
      if (slurm::SlurmUnreachable(what)) {
        WaitForSlurm(job.id, what);
        return;
      }
      for (const JobRecord& with : jobs)
        m_store.FinishJob(with.id, JobState::kFailed, "Slurm refused the job: " + what, {});
      m_log->error("job {}{}: Slurm refused it: {}", job.id,
                   jobs.size() > 1 ? " and " + std::to_string(jobs.size() - 1) + " more" : "",
                   what);
    } catch (const OwnershipError& e) {
      // Its folder is not the daemon's to use (a file or a link where it would go, another
      // account's folder): the jobs fail saying why. Anything else of the system's (a full
      // disk, no file left to open) passes: they wait (below).
      if (NotOursToUse(e))
        for (const JobRecord& with : jobs) FailUnrunnable(with, e.what());
      else
        NoteNotSubmitted(jobs, e.what());
    } catch (const std::exception& e) {
      NoteNotSubmitted(jobs, e.what());
    }
  }
}

void SlurmExecutor::WaitForSlurm(std::int64_t job_id, const std::string& what) {
  // The cluster's trouble, not the job's: it waits, and says why where users look (status,
  // list, the web page, the Python package); logged when the reason changes.
  if (NoteWaitingForSlurm(what))
    m_log->error("job {}: cannot reach Slurm; trying again every {} s: {}", job_id,
                 m_options.slurm.poll_s, what);
}

bool SlurmExecutor::NotOursToUse(const OwnershipError& e) {
  // Allowed: the daemon's own refusals (a link, another account's or an open folder) and a
  // path taken by something that is not a folder.
  const int error = e.system_error();
  return error == 0 || error == ENOTDIR || error == ELOOP;
}

void SlurmExecutor::NoteNotSubmitted(const std::vector<JobRecord>& jobs, std::string what) {
  // The daemon's machine, not the jobs (a full disk, no file descriptor left): they wait,
  // saying why, and the next poll tries them again; the jobs after them go on meanwhile (one
  // such job used to hold up every later one). Logged when the reason changes.
  what = what.substr(0, 400);
  const std::string note = kWaitingToSubmit + what + ")";
  bool changed = false;
  for (const JobRecord& with : jobs) {
    const std::optional<JobRecord> now = m_store.GetJob(with.id);
    if (!now || !Unsubmitted(*now)) {  // failed in its array, or cancelled
      m_not_submitted.erase(with.id);
      continue;
    }
    // Tried again later each time, up to every 5 minutes: each try may write a large bed
    // file into a disk that is full.
    NotSubmitted& wait = m_not_submitted[with.id];
    wait.wait_s = std::min(std::max(2.0 * wait.wait_s, m_options.slurm.poll_s), 300.0);
    wait.next = std::chrono::steady_clock::now() +
                std::chrono::milliseconds(static_cast<std::int64_t>(wait.wait_s * 1000));
    if (now->error == note) continue;  // noted already
    m_store.SetState(with.id, JobState::kQueued, note);
    changed = true;
  }
  if (changed)
    m_log->error("job {}: cannot be submitted for now; trying again, less often each time: {}",
                 jobs.front().id, what);
}

bool SlurmExecutor::NoteWaitingForSlurm(std::string what) {
  what = what.substr(0, 400);
  while (!what.empty() && std::isspace(static_cast<unsigned char>(what.back()))) what.pop_back();
  const std::string note = kWaitingForSlurm + what + ")";
  bool changed = false;
  for (const JobRecord& job : m_store.UnfinishedJobs())
    if (Unsubmitted(job) && job.error != note &&
        job.error.rfind(kWaitingToSubmit, 0) != 0) {  // (that one's own reason first)
      m_store.SetState(job.id, JobState::kQueued, note);
      changed = true;
    }
  return changed;
}

slurm::Submission SlurmExecutor::NewSubmission(const std::string& name, const OwnedFolder& folder,
                                               const JobRecord& job, const Scene& scene,
                                               bool bed_only, std::int64_t after,
                                               const std::vector<std::string>& dembuf_args,
                                               const std::string& nonce) const {
  // A bed file sent with the job goes beside its scene under the name the daemon gives it,
  // and the node's scene names that (the bed's hash is its bytes', whatever the name).
  if (scene.bed.import_bytes) {
    folder.Write(kNodeBedFile, *scene.bed.import_bytes);
    Scene on_node = scene;
    on_node.bed.import = kNodeBedFile;
    folder.Write(report::run_files::kScene, report::SceneText(on_node));
  } else {
    folder.Write(report::run_files::kScene, job.scene_toml);
  }
  const slurm::Settings& settings = m_options.slurm;
  slurm::Submission submission;
  submission.name = name;
  submission.folder = folder.path().string();
  submission.log = (folder.path() / "slurm.log").string();
  if (!nonce.empty()) submission.environment.emplace_back(report::kResultNonceVariable, nonce);
  submission.cpus = settings.cpus_per_job;
  // Whose job it is, in Slurm's accounting: sacct tells the lab's users apart by its comment,
  // and by account and wckey where the cluster keeps them.
  submission.comment = "dembuf_user=" + job.owner;
  if (const auto account = settings.accounts.find(job.owner); account != settings.accounts.end())
    submission.account = account->second;
  if (settings.wckey) submission.wckey = job.owner;
  const ResourceEstimate cost = EstimateResources(scene);
  submission.mem_mb = settings.mem_per_job_mb > 0
                          ? settings.mem_per_job_mb
                          : static_cast<int>(std::ceil(cost.memory_bytes_max * 1.5 / 1e6)) + 256;
  if (!settings.time_limit.empty()) {
    submission.time_s = slurm::ParseTimeLimit(settings.time_limit).value_or(0);
  } else {
    // Three times the prediction and ten minutes more: a slow node or a bed that settles
    // slowly still finishes, and a run that hangs is ended within hours, not days.
    std::vector<std::string> prepared;  // an impact's beds are prepared by jobs before it
    if (!bed_only)
      for (const StageEstimate& stage : cost.stages) prepared.push_back(stage.hash);
    const double predicted = cost.PredictedSeconds(settings.cpus_per_job, prepared);
    submission.time_s = static_cast<int>(std::min(3.0 * predicted + 600.0, 365.0 * 86400));
  }
  if (after != 0) submission.after_ok.push_back(after);
  // The engine runs as many threads as the job has CPUs (Slurm does not bind them here).
  submission.command = {"env", "OMP_NUM_THREADS=" + std::to_string(settings.cpus_per_job),
                        m_options.dembuf};
  submission.command.insert(submission.command.end(), dembuf_args.begin(), dembuf_args.end());
  return submission;
}

std::int64_t SlurmExecutor::BedJob(const std::string& hash, const std::string& stage,
                                   const JobRecord& job, const Scene& scene, std::int64_t after) {
  if (hash.empty() || BedReady(hash)) return 0;
  const std::optional<SlurmBedJob> known = m_store.GetSlurmBed(hash);
  if (known && known->state == "submitted") return known->slurm_id;  // another job's, shared
  const std::string name = BedJobName(hash);
  if (known && known->slurm_id == 0) {
    // Tried before, and sbatch did not say the id (it timed out, or printed none it could be
    // known by), whether or not the record was cancelled since (Slurm may show the job only
    // later): found by name, it is taken up, not prepared twice. Not one that is ending (a
    // bed job cancelled a moment ago is COMPLETING) or waits on a failed dependency: either
    // would fail the job it was given to.
    const std::vector<slurm::JobStatus> found = m_slurm.FindByNamePrefix(name);
    if (const slurm::JobStatus* s = slurm::ChooseCopy(
            found, [&](const slurm::JobStatus& listed) { return listed.name == name; },
            slurm::Liveness::kMayRun)) {
      m_store.PutSlurmBed({hash, stage, s->id, "submitted", "", job.id});
      m_log->warn("job {}: {} {} found in Slurm as job {}; taken up, not submitted again", job.id,
                  BedWords(stage), hash, s->id);
      return s->id;
    }
  }
  const OwnedFolder folder = m_bed_jobs.Folder(hash, true);
  std::vector<std::string> args = {"prepare-bed",
                                   (folder.path() / report::run_files::kScene).string(),
                                   "--bed-cache", m_beds.path().string()};
  if (stage == "source") args.push_back("--source-only");
  m_store.PutSlurmBed({hash, stage, 0, "submitting", "", job.id});  // (its id not yet known)
  const std::int64_t slurm_id =
      m_slurm.Submit(NewSubmission(name, folder, job, scene, true, after, args));
  m_store.PutSlurmBed({hash, stage, slurm_id, "submitted", "", job.id});
  m_log->info("job {}: {} {} is prepared by Slurm job {}", job.id, BedWords(stage), hash, slurm_id);
  return slurm_id;
}

void SlurmExecutor::AddBed(const PreparedBed& bed) {
  // The nodes read their beds from the shared folder's bed cache, a FolderBedStore.
  // Written as FolderBedStore names and reads it, but made exclusively and renamed into
  // place: never through a link a node may have left there.
  m_beds.Write(bed.hash + ".bed", SerializeBed(bed));
}

std::int64_t SlurmExecutor::BedDependency(const JobRecord& job, const Scene& scene) {
  if (job.bed_hash.empty() || BedReady(job.bed_hash)) return 0;
  // Only the source when the bed is cut from one: the source is shared by many beds.
  const std::int64_t source = BedJob(job.source_hash, "source", job, scene, 0);
  const std::vector<BedStage> stages = BedStagesOf(scene);
  return BedJob(job.bed_hash, stages.empty() ? "cut" : stages.back().stage, job, scene, source);
}

std::vector<std::string> SlurmExecutor::RunArgs(const std::string& folder) const {
  return {"run",
          folder + "/" + report::run_files::kScene,
          "--out",
          folder + "/out",
          "--force",
          "--yes",
          "--no-plots",
          "--bed-cache",
          m_beds.path().string(),
          "--samples-out",
          folder + "/samples.bin"};
}

void SlurmExecutor::Submit(const JobRecord& job) {
  const Scene scene = SceneOfJob(m_store, job);
  const std::int64_t bed_after = BedDependency(job, scene);
  const OwnedFolder folder = JobFolder(job.id, true);
  const std::string name = JobName(job.id);
  // The run's proof that its result is its own, kept before the job exists in Slurm: a
  // daemon that dies meanwhile still knows it when it takes the job up.
  const std::string nonce = NewToken();
  m_store.SetResultNonce({job.id}, nonce);
  const std::int64_t slurm_id = m_slurm.Submit(NewSubmission(
      name, folder, job, scene, false, bed_after, RunArgs(folder.path().string()), nonce));
  m_store.SetSlurmId({job.id}, slurm_id);
  m_store.LogEvent(job.id,
                   "submitted to Slurm as job " + std::to_string(slurm_id) + " (" + name + ")");
  m_log->info("job {}: submitted to Slurm as job {}{}", job.id, slurm_id,
              bed_after ? " after its bed, job " + std::to_string(bed_after) : "");
}

std::vector<std::int64_t> SlurmExecutor::SubmitArray(const std::vector<JobRecord>& jobs) {
  const std::int64_t base = jobs.front().id;
  const std::string name = ArrayName(base);
  // One nonce for the array: its tasks are all this daemon's runs.
  const std::string nonce = NewToken();
  // Each task's folder is its job's; the array's words name it through kTaskJobId.
  const std::string task_folder =
      (m_jobs.path() / (m_daemon_id + "-")).string() + std::string(slurm::kTaskJobId);
  // Made first: if it cannot be, every task fails with it (SubmitQueued), none alone before.
  const OwnedFolder folder = ArrayFolder(base, true);
  slurm::Submission array;
  std::set<std::int64_t> after;
  std::vector<std::int64_t> ids;
  for (const JobRecord& job : jobs) {
    std::int64_t bed = 0;
    std::optional<slurm::Submission> task;
    try {
      const Scene scene = SceneOfJob(m_store, job);
      bed = BedDependency(job, scene);
      task = NewSubmission(name, JobFolder(job.id, true), job, scene, false, 0,
                           RunArgs(task_folder), nonce);
    } catch (const SceneError& e) {
      FailUnrunnable(job, e.what());  // this job, not its array
      continue;
    } catch (const SqliteError&) {
      throw;  // the daemon's own store (SubmitQueued)
    } catch (const StoreError&) {
      throw;
    } catch (const slurm::SlurmError& e) {
      if (slurm::SlurmUnreachable(e.what())) throw;
      // The cluster refused this job's bed (memory, time): this job fails, not its array.
      m_store.FinishJob(job.id, JobState::kFailed,
                        std::string("Slurm refused the job of its bed: ") + e.what(), {});
      m_log->error("job {}: Slurm refused the job of its bed: {}", job.id, e.what());
      continue;
    } catch (const OwnershipError& e) {
      if (!NotOursToUse(e)) throw;    // the system's trouble: the array waits (SubmitQueued)
      FailUnrunnable(job, e.what());  // its folder: this job, not its array
      continue;
    }
    if (bed != 0) after.insert(bed);
    ids.push_back(job.id);
    // Every task asks for what the largest needs.
    const int mem_mb = std::max(array.mem_mb, task->mem_mb),
              time_s = std::max(array.time_s, task->time_s);
    if (array.array_tasks.empty()) array = *task;
    array.mem_mb = mem_mb;
    array.time_s = time_s;
    array.array_tasks.push_back(static_cast<int>(job.id - base));
  }
  if (ids.empty()) return ids;
  m_store.SetResultNonce(ids, nonce);
  array.folder = folder.path().string();
  array.log = (folder.path() / "task-%a.log").string();
  array.array_base = base;
  array.array_limit = m_options.slurm.array_limit;
  array.after_ok.assign(after.begin(), after.end());
  const std::int64_t slurm_id = m_slurm.Submit(array);
  m_store.SetSlurmId(ids, slurm_id, base);
  for (const std::int64_t id : ids)
    m_store.LogEvent(id, "submitted to Slurm as task " + std::to_string(id - base) +
                             " of job array " + std::to_string(slurm_id) + " (" + name + ")");
  m_log->info("jobs {} to {}: submitted to Slurm as job array {} of {} tasks{}", base, ids.back(),
              slurm_id, ids.size(),
              after.empty() ? "" : " after their beds' " + std::to_string(after.size()) + " jobs");
  return ids;
}

void SlurmExecutor::FailUnrunnable(const JobRecord& job, const std::string& why) {
  m_store.FinishJob(job.id, JobState::kFailed, "this daemon cannot run the job: " + why, {});
  m_log->error("job {}: cannot run it: {}", job.id, why);
}

void SlurmExecutor::PollBeds(const std::map<slurm::JobKey, slurm::JobStatus>& status) {
  for (SlurmBedJob bed : m_store.SlurmBedsInState("submitted")) {
    const auto it = status.find({bed.slurm_id, -1});
    std::optional<slurm::JobStatus> s;
    if (it != status.end() && it->second.name == BedJobName(bed.hash)) s = it->second;
    if (BedReady(bed.hash)) {
      bed.state = "done";
      m_store.PutSlurmBed(bed);
      m_store.RecordBedPreparation(bed.hash, bed.stage, bed.job_id);
      m_log->info("{} {} is ready (Slurm job {})", BedWords(bed.stage), bed.hash, bed.slurm_id);
      continue;
    }
    if (s && !slurm::IsFinalState(s->state)) continue;
    std::string last;
    try {
      last = LastError(m_bed_jobs.Folder(bed.hash, false));
    } catch (const std::exception& e) {
      last = e.what();
    }
    bed.state = "failed";
    bed.error =
        SlurmReason(s, std::to_string(bed.slurm_id)) + (last.empty() ? "" : "; it said: " + last);
    m_store.PutSlurmBed(bed);
    m_log->error("{} {} could not be prepared: {}", BedWords(bed.stage), bed.hash, bed.error);
    FailDependents(bed.hash, BedWords(bed.stage) + " could not be prepared: " + bed.error);
  }
}

void SlurmExecutor::FailDependents(const std::string& bed_hash, const std::string& why) {
  for (const JobRecord& job : m_store.UnfinishedJobs()) {
    if (job.bed_hash != bed_hash && job.source_hash != bed_hash) continue;
    if (job.state != JobState::kQueued) continue;  // running: its bed was there
    // A bed to be cut from a failed source waits for nothing now.
    if (auto bed = m_store.GetSlurmBed(job.bed_hash);
        bed && job.bed_hash != bed_hash && bed->state == "submitted") {
      m_slurm.Cancel(bed->slurm_id);
      bed->state = "failed";
      bed->error = why;
      m_store.PutSlurmBed(*bed);
    }
    if (job.slurm_id != 0) m_slurm.Cancel(job.slurm_id, job.slurm_task);
    m_store.FinishJob(job.id, JobState::kFailed, why, {});
    m_log->error("job {}: failed: {}", job.id, why);
  }
}

void SlurmExecutor::PollJobs(const std::map<slurm::JobKey, slurm::JobStatus>& status) {
  for (const JobRecord& job : m_store.UnfinishedJobs()) {
    if (job.slurm_id == 0) continue;
    std::optional<slurm::JobStatus> s;
    // A job of that id but another name is not ours: Slurm's ids began again.
    if (const auto it = status.find({job.slurm_id, job.slurm_task});
        it != status.end() && it->second.name == SlurmName(job))
      s = it->second;
    bool began = false, wrote_end = false;
    try {
      const OwnedFolder folder = JobFolder(job.id, false);
      began = folder.Contains("out");
      if (began) {
        const OwnedFolder out = folder.Folder("out", false);
        wrote_end =
            out.Contains(report::run_files::kSummary) || out.Contains(report::run_files::kFailure);
      }
    } catch (const OwnershipError&) {
      wrote_end = true;  // Finish reads it, and fails the job saying what is wrong
    }
    if (!wrote_end && !began && s && ArrayEndedForAnotherBed(job, *s)) continue;
    if (wrote_end || !s || slurm::IsFinalState(s->state)) {
      // A run that began and ended between two looks: it ran all the same.
      if (job.state == JobState::kQueued && began)
        m_store.MarkStarted(job.id, JobState::kRunning, s ? s->node : "", kVersion);
      Finish(job, s);
      continue;
    }
    if (s->state != "RUNNING" && s->state != "COMPLETING") {
      // Waiting: status says for what (its bed, free cores, the partition's limits).
      const std::string note = "Slurm job " + SlurmJobText(job) + " " + ToLower(s->state) +
                               (s->reason.empty() || s->reason == "None" ? "" : ": " + s->reason);
      if (note != job.error) m_store.SetState(job.id, job.state, note);
      continue;
    }
    if (job.state != JobState::kRunning) {
      m_store.MarkStarted(job.id, JobState::kRunning, s->node, kVersion);
      m_store.SetState(job.id, JobState::kRunning);  // (no "pending" note any more)
      m_log->info("job {}: runs on {} (Slurm job {})", job.id, s->node, job.slurm_id);
    }
    Followed* followed = nullptr;
    {
      std::lock_guard lock(m_mutex);
      if (const auto it = m_followed.find(job.id); it != m_followed.end()) followed = &it->second;
    }
    if (!followed) followed = &StartFollowing(job);
    bool followable = true;
    try {
      followable = Follow(job.id, *followed);
    } catch (const SqliteError&) {
      throw;  // the daemon's own store (a full disk): no job's fault; the pass is tried again
    } catch (const StoreError&) {
      throw;
    } catch (const std::exception& e) {
      // What the node left cannot be read (a link, a fifo, the folder gone): this job ends
      // here, and the others are followed on (one such job stalled them all).
      m_log->warn("job {}: its samples cannot be read: {}", job.id, e.what());
      followable = false;
    }
    if (!followable) {
      // More samples than its run may write, or none that can be read: a node gone wrong.
      // Ended here, not taken; Finish says why.
      m_slurm.Cancel(job.slurm_id, job.slurm_task);
      Finish(job, s);
    }
  }
}

bool SlurmExecutor::ArrayEndedForAnotherBed(const JobRecord& job, const slurm::JobStatus& status) {
  // An array waits for every bed its tasks need, and Slurm ends all its tasks when one of
  // them fails. The jobs of that bed have failed already (PollBeds, before this): the others
  // go back to the queue, to be submitted again after their own beds.
  if (job.slurm_task < 0 || job.cancel_requested || status.state != "CANCELLED" ||
      status.reason != "DependencyNeverSatisfied")
    return false;
  const std::string note = "queued again: Slurm ended its job array (" +
                           std::to_string(job.slurm_id) +
                           ") when another job's bed could not be prepared";
  m_store.SetSlurmId({job.id}, 0);
  m_store.SetState(job.id, JobState::kQueued, note);
  m_store.LogEvent(job.id, note);
  m_log->warn("job {}: {}", job.id, note);
  return true;
}

SlurmExecutor::JobBounds SlurmExecutor::BoundsOf(const JobRecord& job) {
  JobBounds bounds;
  try {
    const ResourceEstimate cost = EstimateResources(SceneOfJob(m_store, job));
    bounds.expected_end_s = cost.flight_time_s + cost.impact_steps_max * cost.dt_s;
    bounds.samples_max = static_cast<std::uint64_t>(std::ceil(cost.samples_max)) + 1;
    // The estimate is an upper bound on a run's files; a quarter and a megabyte more leave
    // room for what it leaves out (file system rounding, a longer name), not for more runs.
    const double bytes = cost.output_bytes_max * 1.25 + 1e6;
    bounds.result_bytes_max =
        std::min(m_options.max_result_bytes, static_cast<std::uint64_t>(bytes));
  } catch (const std::exception&) {
    bounds.expected_end_s = 0.0;  // progress unknown; the samples still come
    bounds.samples_max = kMaxSamplesAtEnd;
    bounds.result_bytes_max = m_options.max_result_bytes;
  }
  return bounds;
}

SlurmExecutor::Followed& SlurmExecutor::StartFollowing(const JobRecord& job) {
  Followed followed;
  followed.live = std::make_shared<LiveJob>(job.id, m_store.SeriesLength(job.id));
  followed.live->SetState(JobState::kRunning);
  followed.bounds = BoundsOf(job);
  std::lock_guard lock(m_mutex);
  return m_followed[job.id] = std::move(followed);
}

bool SlurmExecutor::Follow(std::int64_t id, Followed& followed) {
  LiveJob& live = *followed.live;
  auto [first, held] = live.UnstoredSamples();
  const auto read = static_cast<std::uint64_t>(first) + held.size();
  // One sample past what the run may write is enough to tell.
  const std::uint64_t room =
      followed.bounds.samples_max > read ? followed.bounds.samples_max - read : 0;
  const std::vector<ImpactSample> fresh =
      ReadSamples(JobFolder(id, false), read, std::min(kMaxSamplesPerRead, room + 1));
  if (fresh.size() > room) return false;
  for (const ImpactSample& sample : fresh) live.Append(sample);
  if (!fresh.empty()) {
    const double t = fresh.back().t_s;
    live.SetProgress("impact",
                     followed.bounds.expected_end_s > 0 ? t / followed.bounds.expected_end_s : 0.0,
                     t, 0);
  }
  if (live.Unstored() >= static_cast<std::size_t>(m_store.options().chunk_samples)) {
    auto [from, samples] = live.UnstoredSamples();
    m_store.AppendSeries(id, from, samples);
    live.Stored(from + static_cast<std::int64_t>(samples.size()));
  }
  return true;
}

void SlurmExecutor::Finish(const JobRecord& job, const std::optional<slurm::JobStatus>& status) {
  // The samples not yet stored: what the live job holds, then the rest of the file.
  std::shared_ptr<LiveJob> live = Live(job.id);
  std::int64_t first = m_store.SeriesLength(job.id);
  std::vector<ImpactSample> rest;
  if (live) std::tie(first, rest) = live->UnstoredSamples();

  JobState state = JobState::kFailed;
  std::string error;
  std::string summary;
  std::vector<report::ResultFile> files;
  try {
    const OwnedFolder folder = JobFolder(job.id, false);
    // More than its run may write, or than a run writes between two looks: not taken.
    const auto read = static_cast<std::uint64_t>(first) + rest.size();
    const JobBounds bounds = BoundsOf(job);
    const std::uint64_t samples_max = bounds.samples_max;
    const std::uint64_t room =
        std::min(samples_max > read ? samples_max - read : 0, kMaxSamplesAtEnd);
    const std::vector<ImpactSample> tail = ReadSamples(folder, read, room + 1);
    if (tail.size() > room)
      throw std::runtime_error("its samples.bin holds more samples than its run may write (" +
                               std::to_string(samples_max) +
                               ") or the daemon reads at a job's "
                               "end (" +
                               std::to_string(kMaxSamplesAtEnd) + "); none was taken");
    rest.insert(rest.end(), tail.begin(), tail.end());
    std::optional<OwnedFolder> out;
    if (folder.Contains("out")) out = folder.Folder("out", false);
    if (out && out->Contains(report::run_files::kSummary)) {
      summary = ReadRunJson(*out, report::run_files::kSummary, job.result_nonce)->dump(2) + "\n";
      for (auto& [path, data] : out->ReadTree(report::ResultFileRoots(), report::IsSafeResultPath,
                                              bounds.result_bytes_max, kMaxResultFiles))
        files.push_back({path, std::move(data)});
      state = JobState::kDone;
    } else if (out && out->Contains(report::run_files::kFailure)) {
      const nlohmann::json failure =
          *ReadRunJson(*out, report::run_files::kFailure, job.result_nonce);
      error = failure.at("error").get<std::string>().substr(0, 2000) + " (in the " +
              failure.at("phase").get<std::string>().substr(0, 100) + ")";
    } else if (job.cancel_requested) {
      state = JobState::kCancelled;
      error = job.state == JobState::kQueued ? "cancelled while queued" : "cancelled while running";
    } else {
      const std::string last = LastError(job);
      error = SlurmReason(status, SlurmJobText(job)) + (last.empty() ? "" : "; it said: " + last);
    }
  } catch (const std::exception& e) {
    // What a node left is not taken on trust: the job fails saying what is wrong with it.
    state = JobState::kFailed;
    error = std::string("the run ended, but what it left cannot be taken: ") + e.what();
    summary.clear();
    files.clear();
  }
  m_store.FinishJob(job.id, state, error, {summary, std::move(rest), first, std::move(files)});
  if (live) live->End(state);
  {
    std::lock_guard lock(m_mutex);
    m_followed.erase(job.id);
  }
  if (state == JobState::kDone)
    m_log->info("job {}: done (Slurm job {})", job.id, job.slurm_id);
  else
    m_log->warn("job {}: {}: {}", job.id, StateName(state), error);
}

std::string SlurmExecutor::LastError(const JobRecord& job) const {
  if (job.slurm_task < 0) return LastError(JobFolder(job.id, false));
  return LastError(ArrayFolder(job.id - job.slurm_task, false),
                   "task-" + std::to_string(job.slurm_task) + ".log");
}

std::string SlurmExecutor::LastError(const OwnedFolder& folder, const std::string& log) {
  // The log's end: the run's last words are there, however much it printed before.
  std::istringstream in(folder.ReadTail(log, 64 << 10));
  std::string line, last;
  while (std::getline(in, line))
    if (line.rfind("dembuf:", 0) == 0 || line.rfind("slurmstepd:", 0) == 0) last = line;
  if (last.size() > 500) last = last.substr(0, 500) + "...";
  return PrintableText(last);
}

}  // namespace dembuf::server
