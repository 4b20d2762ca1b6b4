#include "doors/api_messages.h"

#include "dembuf/study/sweep/sweep_report.h"
#include "jobs/job_feed.h"

namespace dembuf::server {

namespace {

// The store's job states and the API's, in one table both ways.
constexpr std::pair<JobState, v1::JobState> kStates[] = {
    {JobState::kQueued, v1::JOB_STATE_QUEUED},
    {JobState::kPreparingBed, v1::JOB_STATE_PREPARING_BED},
    {JobState::kRunning, v1::JOB_STATE_RUNNING},
    {JobState::kDone, v1::JOB_STATE_DONE},
    {JobState::kFailed, v1::JOB_STATE_FAILED},
    {JobState::kCancelled, v1::JOB_STATE_CANCELLED}};

}  // namespace

v1::JobState ToProto(JobState state) {
  for (const auto& [ours, theirs] : kStates)
    if (ours == state) return theirs;
  return v1::JOB_STATE_UNSPECIFIED;
}

std::optional<JobState> FromProto(v1::JobState state) {
  for (const auto& [ours, theirs] : kStates)
    if (theirs == state) return ours;
  return std::nullopt;
}

void FillProgress(const JobProgress& p, v1::Progress* out) {
  out->set_stage(p.stage);
  out->set_fraction(p.fraction);
  out->set_sim_time_s(p.sim_time_s);
  out->set_steps(p.steps);
  out->set_peak_plate_force_n(p.peak_plate_force_N);
}

void FillJob(Store& store, Executor& executor, const JobRecord& r, bool with_details, v1::Job* out,
             bool damaged_summary_fails) {
  out->set_id(r.id);
  out->set_sweep_id(r.sweep_id);
  out->set_sweep_index(r.sweep_index);
  for (const auto& v : r.sweep_values) out->add_sweep_values(v);
  out->set_owner(r.owner);
  out->set_name(r.name);
  out->set_error(r.error);
  out->set_scene_hash(r.scene_hash);
  out->set_bed_hash(r.bed_hash);
  out->set_attempts(r.attempts);
  out->set_created_at(r.created_at);
  out->set_started_at(r.started_at);
  out->set_finished_at(r.finished_at);
  out->set_host(r.host);
  out->set_code_version(r.code_version);
  out->set_command_line(r.command_line);
  out->set_slurm_job_id(r.slurm_id);
  if (r.slurm_id != 0 && r.slurm_task >= 0) out->set_slurm_array_task(r.slurm_task);
  out->set_reused_from(r.reused_from);
  out->set_state(ToProto(r.state));
  if (r.P_N) out->set_p_n(*r.P_N);
  FillProgress(ProgressOf(r, executor), out->mutable_progress());
  if (!with_details) return;
  out->set_scene_toml(r.scene_toml);
  for (const auto& bed : store.BedsPreparedBy(r.id)) out->add_beds_prepared(bed);
  for (const JobFileInfo& file : store.JobFiles(r.id)) {
    v1::ResultFileInfo* info = out->add_files();
    info->set_path(file.path);
    info->set_size(file.size);
  }
  // A damaged summary is not served; the job says why it has none.
  if (r.state == JobState::kDone) {
    try {
      out->set_summary_json(store.Summary(r.id));
    } catch (const DamagedData& e) {
      if (damaged_summary_fails) throw;
      out->set_error(e.what());
    }
  }
}

void FillSweep(Store& store, const SweepRecord& r, bool with_aggregates, v1::Sweep* out) {
  out->set_id(r.id);
  out->set_owner(r.owner);
  out->set_name(r.name);
  for (const SweepAxis& axis : r.axes) {
    auto* a = out->add_axes();
    a->set_field(axis.field);
    for (const auto& v : axis.values) a->add_values(v);
  }
  int total = 0;
  for (const auto& [state, count] : store.SweepStateCounts(r.id)) {
    (*out->mutable_jobs_by_state())[state] = count;
    total += count;
  }
  out->set_jobs_total(total);
  out->set_created_at(r.created_at);
  out->set_beds_prepared(store.SweepBedsPrepared(r.id));
  if (with_aggregates) out->set_aggregates_json(SweepAggregatesJson(r, store.SweepResults(r.id)));
}

bool FillSweepList(Store& store, const std::string& owner, int limit,
                   google::protobuf::RepeatedPtrField<v1::Sweep>* out) {
  std::int64_t bytes = 0;
  for (const SweepRecord& sweep : store.ListSweeps(owner, limit)) {
    v1::Sweep* message = out->Add();
    FillSweep(store, sweep, false, message);
    bytes += static_cast<std::int64_t>(message->ByteSizeLong());
    if (bytes > kMaxListAnswerBytes) return false;
  }
  return true;
}

std::string SweepAggregatesJson(const SweepRecord& r, const std::vector<SweepJobResult>& jobs) {
  // The jobs as the sweep report's runs: done ones with their summaries.
  std::vector<SweepRunReport> runs;
  for (const SweepJobResult& job : jobs) {
    SweepRunReport run;
    run.values = job.sweep_values;
    run.values.resize(r.axes.size());  // (a damaged row cannot make the points fail)
    run.state = StateName(job.state);
    if (job.state == JobState::kDone && !job.summary_json.empty()) {
      // Only the metrics are kept: a sweep's summaries whole would be held at once.
      const nlohmann::json summary =
          nlohmann::json::parse(job.summary_json, nullptr, /*allow_exceptions=*/false);
      run.ok = summary.is_object();
      run.summary = nlohmann::json::object();
      for (const std::string& m : SweepMetricNames())
        if (run.ok && summary.contains(m)) run.summary[m] = summary[m];
    }
    runs.push_back(std::move(run));
  }
  return SweepAggregates(r.axes, runs).dump();
}

}  // namespace dembuf::server
