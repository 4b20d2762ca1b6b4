#include "doors/admission.h"

#include <algorithm>

#include "dembuf/study/scene/errors.h"
#include "dembuf/study/scene/scene_fields.h"
#include "doors/scene_request.h"

namespace dembuf::server {

namespace {

// One answer for every path a request names, so that it tells nothing of the daemon's disk.
constexpr const char* kReadsNoFiles =
    "the server reads no files of its own; a bed file goes with the request, and a sweep "
    "cannot vary it (dembuf submit and sweep send the file bed.import names)";

void AdmitBedImport(const Scene& scene, const std::optional<BedFile>& sent) {
  if (scene.bed.import.empty()) return;
  if (!sent || !scene.bed.import_bytes || scene.bed.import != sent->name)
    throw SceneError("bed.import", kReadsNoFiles);
}

void AdmitSnapshots(const Scene& scene) {
  // Their bytes are bounded by the estimate (quota_output_mb); their number here, so that many
  // tiny snapshots cannot flood the store with rows.
  const std::size_t snapshots = scene.output.snapshot_times_s.size() +
                                scene.output.snapshot_after_contact_s.size() +
                                (scene.output.snapshot_at_peak ? 1 : 0);
  if (snapshots > kMaxServerSnapshots)
    throw SceneError(
        scene.output.snapshot_times_s.size() > scene.output.snapshot_after_contact_s.size()
            ? "output.snapshot_times_s"
            : "output.snapshot_after_contact_s",
        std::to_string(snapshots) + " snapshots; a server job takes at most " +
            std::to_string(kMaxServerSnapshots));
}

}  // namespace

ResourceEstimate AdmitScene(const Scene& scene, const std::optional<BedFile>& sent,
                            const ResourceLimits& limits) {
  // The bed file first: nothing below may look a path up.
  AdmitBedImport(scene, sent);
  ValidateScene(scene);
  AdmitSnapshots(scene);
  ResourceEstimate estimate = EstimateResources(scene);
  CheckResources(estimate, limits, scene, "this server's");
  return estimate;
}

AdmittedJob AdmitJob(const v1::SceneSpec& spec, const std::optional<BedFile>& sent,
                     const ResourceLimits& limits) {
  AdmittedJob job{ResolveSceneSpec(spec, sent)};
  job.output_bytes = AdmitScene(job.scene, sent, limits).output_bytes_max;
  return job;
}

namespace {

void CheckSweepShape(const v1::SubmitSweepRequest& request) {
  if (request.axes().empty() && request.table().rows().empty() && request.seeds() <= 1)
    throw SceneError("axes", "a sweep needs at least one axis, a table or seeds > 1");
  const int seeds = request.seeds() == 0 ? 1 : request.seeds();
  if (const std::string problem = SweepSeedsProblem(seeds); !problem.empty())
    throw SceneError("seeds", problem);
  CheckSweepAxes(request);
}

}  // namespace

AdmittedSweep AdmitSweep(const v1::SubmitSweepRequest& request,
                         const std::function<std::optional<BedFile>()>& sent_file,
                         const ResourceLimits& limits, std::size_t max_runs,
                         const std::function<bool()>& cancelled) {
  CheckSweepShape(request);
  const std::optional<BedFile> sent = sent_file();
  const int seeds = request.seeds() == 0 ? 1 : request.seeds();  // (0, the default, is one)
  const Scene base = ResolveSceneSpec(request.base(), sent);
  AdmittedSweep sweep;
  // A table's columns first, read row by row (TableAxes checks each value and row).
  if (request.has_table()) {
    if (static_cast<std::size_t>(request.table().rows_size()) > max_runs)
      throw SceneError("table", std::to_string(request.table().rows_size()) +
                                    " rows; a sweep has at most " + std::to_string(max_runs) +
                                    " runs here");
    dembuf::SweepTable table;  // (not the store's table of sweeps)
    table.fields.assign(request.table().fields().begin(), request.table().fields().end());
    for (const auto& row : request.table().rows())
      table.rows.emplace_back(row.values().begin(), row.values().end());
    sweep.axes = TableAxes(table);
  }
  const std::size_t table_columns = sweep.axes.size();
  for (const auto& axis : request.axes()) {
    const std::vector<std::string> values(axis.values().begin(), axis.values().end());
    sweep.axes.push_back(MakeSweepAxis(axis.field(), values, axis.range()));
  }
  sweep.axes = WithSeedAxis(sweep.axes, seeds, base.bed.seed);
  // Each run as soon as its axes are set: before anything looks at what they name.
  sweep.runs = ExpandSweep(
      base, sweep.axes, max_runs,
      [&](const Scene& run) {
        if (cancelled && cancelled()) throw Cancelled();  // no work for a caller who left
        sweep.output_bytes += AdmitScene(run, sent, limits).output_bytes_max;
      },
      table_columns);
  sweep.axes = DistinctAxes(std::move(sweep.axes));  // as the sweep's record keeps them
  return sweep;
}

}  // namespace dembuf::server
