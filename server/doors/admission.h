// The one gate every job passes before it is stored, whatever request brought it: the scene
// a worker will run (after the preset, the scene file, the accuracy, the typed fields, the
// assignments, a sweep's axes and seeds) together with the bed file sent with it. SubmitJob
// asks it of its scene, SubmitSweep of every run's (through ExpandSweep, as soon as the axes
// are set); the executors run only what passed, and read no path a request named.
#pragma once

#include <cstddef>
#include <functional>
#include <optional>

#include <vector>

#include "dembuf/study/run/resource_estimate.h"
#include "dembuf/study/scene/scene.h"
#include "dembuf/study/sweep/sweep_plan.h"
#include "dembuf/v1/dembuf.pb.h"
#include "jobs/job_scene.h"
#include "store/store.h"

namespace dembuf::server {

/// Admits `scene` and returns its resource estimate, or throws: SceneError naming the field,
/// or ResourceError naming the limit. Admitted:
///  - bed.import is empty, or names exactly the bed file `sent` with the request (whose bytes
///    the scene carries): the daemon reads no file of its own, and its refusal is the same
///    whether a path it was given exists or not;
///  - every field is in range (ValidateScene);
///  - at most kMaxServerSnapshots snapshots, whose bytes the estimate bounds;
///  - its resource estimate is within `limits` (the daemon's quota_* settings).
ResourceEstimate AdmitScene(const Scene& scene, const std::optional<BedFile>& sent,
                            const ResourceLimits& limits);

/// A job's scene from its request, admitted, and the bytes its results may store at most.
/// `sent` is the bed file the spec names, if any.
struct AdmittedJob {
  Scene scene;
  double output_bytes = 0.0;
};
AdmittedJob AdmitJob(const v1::SceneSpec& spec, const std::optional<BedFile>& sent,
                     const ResourceLimits& limits);

/// A sweep's axes (its seeds among them) and runs from its request, every run admitted as it
/// will run: at most `max_runs` of them.
struct AdmittedSweep {
  std::vector<SweepAxis> axes;
  std::vector<SweepRun> runs;
  double output_bytes = 0.0;  ///< what their results may store at most, in all
};
/// The sweep's shape is checked first, before anything it names is read: an axis or more than
/// one seed (SweepSeedsProblem: 1 to 1000; 0 is one), and the axes' limits (CheckSweepAxes).
/// Only then is `sent_file` asked for the bed file its base names (if any). `cancelled`, when
/// given, is asked before each run: true throws Cancelled (the caller left).
AdmittedSweep AdmitSweep(const v1::SubmitSweepRequest& request,
                         const std::function<std::optional<BedFile>()>& sent_file,
                         const ResourceLimits& limits, std::size_t max_runs,
                         const std::function<bool()>& cancelled = {});

}  // namespace dembuf::server
