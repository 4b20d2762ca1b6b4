#include "api_json.h"

#include <cctype>
#include <map>
#include <vector>

#include "dembuf/study/scene/scene_fields.h"
#include "dembuf/study/sweep/sweep_report.h"
#include "dembuf/study/text/text_limits.h"

namespace dembuf::api {

std::string StateText(v1::JobState state) {
  // The enum's own name without its prefix, as the daemon stores and filters states.
  std::string name = v1::JobState_Name(state);
  const std::string prefix = "JOB_STATE_";
  if (name.rfind(prefix, 0) == 0) name = name.substr(prefix.size());
  for (char& c : name) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return name;
}

namespace {

// A JSON object sent as text (a summary, a sweep's aggregates): null when there is none or it
// is not an object. A text past the bounds of JSON from outside throws InputLimitError.
nlohmann::json ParsedObject(const std::string& text, const std::string& what,
                            std::size_t max_bytes = std::size_t{16} << 20) {
  if (text.empty()) return nullptr;
  nlohmann::json object = ParseBoundedJson(text, what, max_bytes);
  return object.is_object() ? object : nlohmann::json();
}

std::vector<std::string> Strings(const google::protobuf::RepeatedPtrField<std::string>& list) {
  return {list.begin(), list.end()};
}

// An empty text (not started, no error) and a zero id (no sweep, no Slurm job) as null.
nlohmann::json TextOrNull(const std::string& text) {
  return text.empty() ? nlohmann::json() : nlohmann::json(text);
}
nlohmann::json IdOrNull(std::int64_t id) {
  return id ? nlohmann::json(id) : nlohmann::json();
}

}  // namespace

nlohmann::json ProgressJson(const v1::Progress& p) {
  return {{"stage", p.stage()},
          {"fraction", p.fraction()},
          {"sim_time_s", p.sim_time_s()},
          {"steps", p.steps()},
          {"peak_plate_force_N", p.peak_plate_force_n()}};
}

nlohmann::json JobJson(const v1::Job& job, bool details) {
  const v1::Progress& p = job.progress();
  nlohmann::json out = {
      {"id", job.id()},
      {"name", job.name()},
      {"owner", job.owner()},
      {"state", StateText(job.state())},
      {"error", TextOrNull(job.error())},
      {"sweep_id", IdOrNull(job.sweep_id())},
      {"sweep_index", job.sweep_index()},
      {"sweep_values", SweepValuesJson(Strings(job.sweep_values()))},
      {"attempts", job.attempts()},
      {"created_at", TextOrNull(job.created_at())},
      {"started_at", TextOrNull(job.started_at())},
      {"finished_at", TextOrNull(job.finished_at())},
      {"host", job.host()},
      {"code_version", job.code_version()},
      {"command_line", job.command_line()},
      {"progress", ProgressJson(p)},
      // The peak so far while it runs, the summary's once done; null before any.
      {"peak_plate_force_N",
       p.peak_plate_force_n() > 0.0 ? nlohmann::json(p.peak_plate_force_n()) : nlohmann::json()},
      {"P_N", job.has_p_n() ? nlohmann::json(job.p_n()) : nlohmann::json()},
      {"slurm_job_id", IdOrNull(job.slurm_job_id())},
      {"slurm_array_task",
       job.has_slurm_array_task() ? nlohmann::json(job.slurm_array_task()) : nlohmann::json()},
      {"reused_from", IdOrNull(job.reused_from())},
  };
  if (!details) return out;
  out["scene_toml"] = job.scene_toml();
  out["scene_hash"] = job.scene_hash();
  out["bed_hash"] = job.bed_hash();
  out["summary"] =
      ParsedObject(job.summary_json(), "job " + std::to_string(job.id()) + "'s summary_json");
  nlohmann::json files = nlohmann::json::array();
  for (const v1::ResultFileInfo& f : job.files())
    files.push_back({{"path", f.path()}, {"size", f.size()}});
  out["files"] = files;
  out["beds_prepared"] = Strings(job.beds_prepared());
  return out;
}

nlohmann::json SweepJson(const v1::Sweep& sweep, bool details) {
  nlohmann::json axes = nlohmann::json::array();
  for (const v1::SweepAxis& axis : sweep.axes()) {
    const SceneField* field = FindSceneField(axis.field());
    axes.push_back({{"field", axis.field()},
                    {"values", SweepValuesJson(Strings(axis.values()))},
                    {"unit", field ? std::string(field->unit) : ""},
                    {"help", field ? std::string(field->help) : ""}});
  }
  // Sorted by state name, so that the output does not depend on the map's order.
  const std::map<std::string, int> by_state(sweep.jobs_by_state().begin(),
                                            sweep.jobs_by_state().end());
  nlohmann::json out = {{"id", sweep.id()},
                        {"name", sweep.name()},
                        {"owner", sweep.owner()},
                        {"created_at", sweep.created_at()},
                        {"axes", axes},
                        {"jobs_total", sweep.jobs_total()},
                        {"jobs_by_state", by_state},
                        {"beds_prepared", sweep.beds_prepared()}};
  if (!details) return out;
  // The study layer's aggregates as the daemon computed them: points (flat objects, the rows
  // of points.csv, whose header is point_columns), and Hc where there is one (null where the
  // sweep is not over the thickness alone).
  const nlohmann::json aggregates = ParsedObject(
      sweep.aggregates_json(), "sweep " + std::to_string(sweep.id()) + "'s aggregates_json",
      kMaxAggregatesBytes);
  const bool whole =
      aggregates.is_object() && aggregates.contains("points") && aggregates["points"].is_array();
  // (null where the server sent none: a daemon before aggregates)
  out["points"] = whole ? aggregates["points"] : nlohmann::json();
  out["point_columns"] = whole && aggregates.contains("point_columns") ? aggregates["point_columns"]
                                                                       : nlohmann::json();
  out["Hc_m"] = whole && aggregates.contains("Hc_m") ? aggregates["Hc_m"] : nlohmann::json();
  out["critical_thickness"] = whole && aggregates.contains("critical_thickness")
                                  ? aggregates["critical_thickness"]
                                  : nlohmann::json();
  return out;
}

}  // namespace dembuf::api
