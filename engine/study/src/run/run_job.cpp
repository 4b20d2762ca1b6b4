#include "dembuf/study/run/run_job.h"

#include "dembuf/study/files/run_output.h"
#include "dembuf/study/scene/species.h"

namespace dembuf {

ImpactSummary RunJob(const Scene& scene, BedCache& beds, const JobControl& control,
                     RunRecorder& recorder) {
  report::RunContext context = control.context;
  if (context.started_at.empty()) context.started_at = report::UtcNow();

  BedRequest bed_request;
  bed_request.cancel = control.steering.cancel;
  bed_request.threads = control.steering.threads;
  bed_request.on_progress = control.on_bed_progress;
  World world = BuildWorld(scene, &beds, &bed_request);
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

  context.finished_at = report::UtcNow();
  context.threads = summary.threads;
  recorder.Finished(summary, report::SummaryToJson(summary, scene, context));
  return summary;
}

}  // namespace dembuf
