#include "doors/web/web_views.h"

#include <charconv>
#include <cmath>

#include "api_json.h"
#include "dembuf/study/files/run_output.h"
#include "dembuf/study/sweep/sweep_report.h"
#include "doors/api_messages.h"

namespace dembuf::server::web {

nlohmann::json JobJson(Store& store, Executor& executor, const JobRecord& job, bool details) {
  v1::Job message;
  FillJob(store, executor, job, details, &message);
  return api::JobJson(message, details);
}

nlohmann::json SweepJson(Store& store, const SweepRecord& sweep) {
  v1::Sweep message;
  FillSweep(store, sweep, /*with_aggregates=*/false, &message);
  const std::vector<SweepJobResult> jobs = store.SweepResults(sweep.id);
  message.set_aggregates_json(SweepAggregatesJson(sweep, jobs));
  nlohmann::json out = api::SweepJson(message, /*details=*/true);
  nlohmann::json job_list = nlohmann::json::array();
  for (const SweepJobResult& job : jobs)
    job_list.push_back({{"id", job.id},
                        {"sweep_index", job.sweep_index},
                        {"values", SweepValuesJson(job.sweep_values)},
                        {"state", StateName(job.state)}});
  out["jobs"] = job_list;
  return out;
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
  v1::Progress message;
  FillProgress(progress, &message);
  return {{"state", StateName(state)}, {"progress", api::ProgressJson(message)}};
}

}  // namespace dembuf::server::web
