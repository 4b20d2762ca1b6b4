#include "dembuf/study/run/run_job.h"

#include <algorithm>
#include <cstdio>

#include "dembuf/study/files/run_output.h"
#include "dembuf/study/scene/species.h"

namespace dembuf {

ImpactSummary RunJob(const Scene& scene, BedCache& beds, const JobControl& control,
                     RunRecorder& recorder) {
  report::RunContext context = control.context;
  if (context.started_at.empty()) context.started_at = report::UtcNow();

  // The timeline of log.txt: each bed stage as it starts, the impact's start and end.
  auto note = [&](const std::string& text) {
    context.timeline.push_back(report::UtcNow() + " " + text);
  };
  note("started: " + std::string(scene.bed.thickness_m > 0 ? "the bed" : "no bed") + ", seed " +
       std::to_string(scene.bed.seed));
  BedRequest bed_request;
  bed_request.cancel = control.steering.cancel;
  bed_request.threads = control.steering.threads;
  std::vector<std::string> bed_stages;  // each noted once, when it first starts
  bed_request.on_progress = [&](const BedProgress& p) {
    if (std::find(bed_stages.begin(), bed_stages.end(), p.stage) == bed_stages.end()) {
      note("bed: " + p.stage + ", " + std::to_string(p.beads) + " beads");
      bed_stages.push_back(p.stage);
    }
    if (control.on_bed_progress) control.on_bed_progress(p);
  };
  World world = BuildWorld(scene, &beds, &bed_request);
  note("impact: " + std::to_string(world.beads.size()) + " beads" +
       (bed_stages.empty() && scene.bed.thickness_m > 0 ? ", the bed from the cache" : ""));
  if (control.on_bed_ready) control.on_bed_ready(world);

  RunControl impact;
  impact.on_sample = [&](const ImpactSample& s) { recorder.Sample(s); };
  impact.on_reference_sample = [&](const ImpactSample& s) { recorder.ReferenceSample(s); };
  report::ParaViewFiles paraview(scene.cylinder.radius_m, scene.cylinder.height_m,
                                 LargestDiameter(scene));
  impact.on_snapshot = [&](const ImpactSnapshot& snap) {
    recorder.Files(paraview.AddSnapshot(snap));
  };
  // The frames in the formats asked for: ParaView's, LAMMPS dumps (for OVITO), or both.
  const std::string& frame_format = scene.output.frame_format;
  std::int64_t frame_number = 0;
  impact.on_frame = [&](const ImpactSnapshot& frame) {
    std::vector<report::ResultFile> files;
    if (frame_format != "lammps") files = paraview.AddFrame(frame);
    if (frame_format != "vtp")
      files.push_back({report::FramePath(frame, ".dump"),
                       report::LammpsDumpFrame(frame, frame_number, scene.cylinder.radius_m,
                                               scene.cylinder.height_m)});
    ++frame_number;
    recorder.Files(files);
  };
  impact.steering = control.steering;
  impact.beds = &beds;
  impact.bed_request = &bed_request;
  const ImpactSummary summary = RunImpact(std::move(world), scene, impact);

  char end[160];
  std::snprintf(end, sizeof end, "ended at %.4f ms (%s), peak plate force %.6g N, %lld steps",
                summary.end_time_s * 1e3, summary.end_reason.c_str(), summary.peak_plate_force_N,
                static_cast<long long>(summary.steps));
  note(end);
  context.finished_at = report::UtcNow();
  context.threads = summary.threads;
  recorder.Finished(summary, report::SummaryToJson(summary, scene, context));
  return summary;
}

}  // namespace dembuf
