#include "web_views.h"

#include <charconv>
#include <cmath>

#include "dembuf/study/files/run_output.h"
#include "dembuf/study/scene/scene_fields.h"
#include "dembuf/study/sweep/sweep_report.h"

namespace dembuf::server::web {

namespace {

nlohmann::json ProgressObject(const JobProgress& p) {
  return {{"stage", p.stage},
          {"fraction", p.fraction},
          {"sim_time_s", p.sim_time_s},
          {"steps", p.steps},
          {"peak_plate_force_N", p.peak_plate_force_N}};
}

}  // namespace

nlohmann::json ParseSummary(const std::string& summary_json) {
  if (summary_json.empty()) return nullptr;
  nlohmann::json summary = nlohmann::json::parse(summary_json, nullptr, /*allow_exceptions=*/false);
  return summary.is_discarded() || !summary.is_object() ? nlohmann::json() : summary;
}

nlohmann::json JobJson(const JobRecord& job, const JobProgress& progress,
                       const std::string& summary_json) {
  nlohmann::json peak;  // null: not known
  const nlohmann::json summary = ParseSummary(summary_json);
  if (summary.is_object() && summary.contains("peak_plate_force_N"))
    peak = summary["peak_plate_force_N"];
  else if (progress.peak_plate_force_N > 0.0)
    peak = progress.peak_plate_force_N;
  nlohmann::json p_n;
  if (summary.is_object() && summary.contains("P_N")) p_n = summary["P_N"];
  // The shape of `dembuf status --json` and the Python package's job(): null for what is not
  // there (no sweep, not yet started or finished, no Slurm job).
  auto time = [](const std::string& iso) {
    return iso.empty() ? nlohmann::json() : nlohmann::json(iso);
  };
  auto id_or_null = [](std::int64_t id) { return id ? nlohmann::json(id) : nlohmann::json(); };
  return {{"id", job.id},
          {"name", job.name},
          {"owner", job.owner},
          {"state", StateName(job.state)},
          {"error", job.error.empty() ? nlohmann::json() : nlohmann::json(job.error)},
          {"sweep_id", id_or_null(job.sweep_id)},
          {"sweep_index", job.sweep_index},
          {"sweep_values", report::SweepValuesJson(job.sweep_values)},
          {"attempts", job.attempts},
          {"created_at", time(job.created_at)},
          {"started_at", time(job.started_at)},
          {"finished_at", time(job.finished_at)},
          {"host", job.host},
          {"code_version", job.code_version},
          {"command_line", job.command_line},
          {"progress", ProgressObject(progress)},
          {"peak_plate_force_N", peak},
          {"P_N", p_n},
          {"slurm_job_id", id_or_null(job.slurm_id)}};
}

nlohmann::json JobDetailsJson(const JobRecord& job, const JobProgress& progress,
                              const std::string& summary_json,
                              const std::vector<JobFileInfo>& files,
                              const std::vector<std::string>& beds_prepared) {
  nlohmann::json out = JobJson(job, progress, summary_json);
  out["scene_toml"] = job.scene_toml;
  out["scene_hash"] = job.scene_hash;
  out["bed_hash"] = job.bed_hash;
  out["summary"] = ParseSummary(summary_json);
  nlohmann::json file_list = nlohmann::json::array();
  for (const JobFileInfo& f : files) file_list.push_back({{"path", f.path}, {"size", f.size}});
  out["files"] = file_list;
  out["beds_prepared"] = beds_prepared;
  return out;
}

nlohmann::json SweepJson(const SweepRecord& sweep, const std::vector<SweepJobResult>& jobs) {
  nlohmann::json axes = nlohmann::json::array();
  for (const SweepAxis& axis : sweep.axes) {
    const SceneField* field = FindSceneField(axis.field);
    axes.push_back({{"field", axis.field},
                    {"values", report::SweepValuesJson(axis.values)},
                    {"unit", field ? std::string(field->unit) : ""},
                    {"help", field ? std::string(field->help) : ""}});
  }
  // The jobs as the sweep report's runs: done ones with their summaries.
  std::vector<report::SweepRunReport> runs;
  nlohmann::json by_state = nlohmann::json::object();
  nlohmann::json job_list = nlohmann::json::array();
  for (const SweepJobResult& job : jobs) {
    report::SweepRunReport run;
    run.values = job.sweep_values;
    run.values.resize(sweep.axes.size());  // (a damaged row cannot make the points fail)
    run.summary = job.state == JobState::kDone ? ParseSummary(job.summary_json) : nullptr;
    run.ok = run.summary.is_object();
    run.error = job.error;
    runs.push_back(std::move(run));
    const std::string state = StateName(job.state);
    by_state[state] = by_state.value(state, 0) + 1;
    job_list.push_back({{"id", job.id},
                        {"sweep_index", job.sweep_index},
                        {"values", report::SweepValuesJson(job.sweep_values)},
                        {"state", state}});
  }
  return {{"id", sweep.id},
          {"name", sweep.name},
          {"owner", sweep.owner},
          {"created_at", sweep.created_at},
          {"axes", axes},
          {"jobs_total", jobs.size()},
          {"jobs_by_state", by_state},
          {"jobs", job_list},
          {"points", report::SweepPoints(sweep.axes, runs)}};
}

std::string SamplesJson(std::int64_t first, const std::vector<ImpactSample>& samples) {
  std::string text;
  text.reserve(64 + samples.size() * 5 * 24);
  text += "{\"first\":" + std::to_string(first);
  // The columns of plate_force.csv, by the same table.
  for (const report::SampleColumn& c : report::SampleColumns()) {
    text += ",\"";
    text += c.name;
    text += "\":[";
    char number[32];
    for (std::size_t k = 0; k < samples.size(); ++k) {
      if (k) text += ',';
      const double v = report::SampleValue(samples[k], c);
      if (!std::isfinite(v)) {
        text += "null";
        continue;
      }
      // The shortest text that reads back as the same double.
      const auto end = std::to_chars(number, number + sizeof number, v).ptr;
      text.append(number, end);
    }
    text += ']';
  }
  text += '}';
  return text;
}

nlohmann::json ProgressJson(JobState state, const JobProgress& progress) {
  return {{"state", StateName(state)}, {"progress", ProgressObject(progress)}};
}

}  // namespace dembuf::server::web
