#include "remote_json.h"

#include <cctype>
#include <map>
#include <vector>

#include "dembuf/study/sweep/sweep_report.h"
#include "dembuf/study/text/text_limits.h"

namespace dembuf::cli {

std::string StateText(v1::JobState state) {
  // The enum's own name without its prefix, as the daemon stores and filters states.
  std::string name = v1::JobState_Name(state);
  const std::string prefix = "JOB_STATE_";
  if (name.rfind(prefix, 0) == 0) name = name.substr(prefix.size());
  for (char& c : name) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return name;
}

namespace {

// A summary.json text as an object (null when there is none or it is not an object). A text
// past the bounds of JSON from outside throws InputLimitError naming the job's summary.
nlohmann::json ParsedSummary(const v1::Job& job) {
  if (job.summary_json().empty()) return nullptr;
  nlohmann::json summary =
      ParseBoundedJson(job.summary_json(), "job " + std::to_string(job.id()) + "'s summary_json");
  return summary.is_object() ? summary : nlohmann::json();
}

std::vector<std::string> Strings(const google::protobuf::RepeatedPtrField<std::string>& list) {
  return {list.begin(), list.end()};
}

// An empty time (not started, not finished) as null.
nlohmann::json Time(const std::string& iso) {
  return iso.empty() ? nlohmann::json() : nlohmann::json(iso);
}

}  // namespace

nlohmann::json JobJson(const v1::Job& job, bool details) {
  const nlohmann::json summary = ParsedSummary(job);
  const v1::Progress& p = job.progress();
  nlohmann::json out = {
      {"id", job.id()},
      {"name", job.name()},
      {"owner", job.owner()},
      {"state", StateText(job.state())},
      {"error", job.error().empty() ? nlohmann::json() : nlohmann::json(job.error())},
      {"sweep_id", job.sweep_id() ? nlohmann::json(job.sweep_id()) : nlohmann::json()},
      {"sweep_index", job.sweep_index()},
      {"sweep_values", report::SweepValuesJson(Strings(job.sweep_values()))},
      {"attempts", job.attempts()},
      {"created_at", Time(job.created_at())},
      {"started_at", Time(job.started_at())},
      {"finished_at", Time(job.finished_at())},
      {"host", job.host()},
      {"code_version", job.code_version()},
      {"command_line", job.command_line()},
      {"progress",
       {{"stage", p.stage()},
        {"fraction", p.fraction()},
        {"sim_time_s", p.sim_time_s()},
        {"steps", p.steps()},
        {"peak_plate_force_N", p.peak_plate_force_n()}}},
      // The summary's peak once finished, the peak so far while running (as /api/jobs).
      {"peak_plate_force_N", summary.is_object() && summary.contains("peak_plate_force_N")
                                 ? summary["peak_plate_force_N"]
                             : p.peak_plate_force_n() > 0.0 ? nlohmann::json(p.peak_plate_force_n())
                                                            : nlohmann::json()},
      {"P_N", summary.is_object() && summary.contains("P_N") ? summary["P_N"] : nlohmann::json()},
      {"slurm_job_id", job.slurm_job_id() ? nlohmann::json(job.slurm_job_id()) : nlohmann::json()},
  };
  if (!details) return out;
  out["scene_toml"] = job.scene_toml();
  out["scene_hash"] = job.scene_hash();
  out["bed_hash"] = job.bed_hash();
  out["summary"] = summary;
  nlohmann::json files = nlohmann::json::array();
  for (const v1::ResultFileInfo& f : job.files())
    files.push_back({{"path", f.path()}, {"size", f.size()}});
  out["files"] = files;
  out["beds_prepared"] = Strings(job.beds_prepared());
  return out;
}

nlohmann::json SweepJson(const v1::Sweep& sweep) {
  nlohmann::json axes = nlohmann::json::array();
  for (const v1::SweepAxis& axis : sweep.axes())
    axes.push_back({{"field", axis.field()},
                    {"values", report::SweepValuesJson(Strings(axis.values()))},
                    {"range", axis.range()}});
  // Sorted by state name, so that the output does not depend on the map's order.
  const std::map<std::string, int> by_state(sweep.jobs_by_state().begin(),
                                            sweep.jobs_by_state().end());
  return {{"id", sweep.id()},
          {"name", sweep.name()},
          {"owner", sweep.owner()},
          {"created_at", sweep.created_at()},
          {"axes", axes},
          {"jobs_total", sweep.jobs_total()},
          {"jobs_by_state", by_state},
          {"beds_prepared", sweep.beds_prepared()}};
}

nlohmann::json ServerInfoJson(const v1::ServerInfoResponse& info, const std::string& address) {
  return {
      {"version", info.version()},
      {"address", address},
      {"host", info.host()},
      {"started_at", info.started_at()},
      {"executor", info.executor()},
      {"workers", info.workers()},
      {"threads_per_job", info.threads_per_job()},
      {"running", info.running()},
      {"queue_depth", info.queue_depth()},
      {"queue_limit", info.queue_limit()},
      {"database", info.database().empty() ? nlohmann::json() : nlohmann::json(info.database())},
      {"stored_bytes", info.stored_bytes()},
      {"quota_stored_bytes", info.quota_stored_bytes()},
      {"queued_jobs", info.queued_jobs()},
      {"quota_queued_jobs", info.quota_queued_jobs()}};
}

}  // namespace dembuf::cli
