// One run of a scene, wired once. RunJob finds or prepares the bed, runs the impact and its
// bare-plate reference, takes the snapshots and animation frames and measures; what it makes
// goes to a RunRecorder as it comes. The CLI's run, a sweep's runs and a cluster job record into
// a folder (FolderRecorder), the daemon into its store; each caller adds only its own concerns
// (progress lines, job states, failure reports).
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <nlohmann/json.hpp>
#include <vector>

#include "dembuf/study/bed/bed.h"
#include "dembuf/study/files/provenance.h"
#include "dembuf/study/files/snapshot_report.h"
#include "dembuf/study/impact/impact.h"
#include "dembuf/study/scene/scene.h"

namespace dembuf {

/// Where a run's results go, in the order RunJob gives them: samples (and the bare-plate
/// reference's) while the impact runs, the files of each snapshot and frame as it is taken,
/// then, when the run ends well, its summary. A run that fails or is cancelled ends with an
/// exception instead of Finished: what was recorded so far is all there is.
class RunRecorder {
 public:
  virtual ~RunRecorder() = default;
  /// One sample of the plate force series (every time.output_interval_s).
  virtual void Sample(const ImpactSample& sample) = 0;
  /// One sample of the same impact on the bare plate, run for lambda's Pa0.
  virtual void ReferenceSample(const ImpactSample& sample) = 0;
  /// The files of a snapshot or an animation frame, with its .pvd collection brought up to date
  /// (paths relative to the run's folder).
  virtual void Files(const std::vector<report::ResultFile>& files) = 0;
  /// The run ended well: its summary and the summary.json document made of it.
  virtual void Finished(const ImpactSummary& summary, const nlohmann::json& summary_json) = 0;
};

/// How the caller watches and steers a run.
struct JobControl {
  /// Who asked and where it runs; RunJob sets started_at (when empty), finished_at and the
  /// threads the impact ran on at its end.
  report::RunContext context;
  /// Cancel, threads and the impact's progress: handed to the beds and the impact as they are.
  RunSteering steering;
  std::function<void(const BedProgress&)> on_bed_progress;  ///< while a bed is prepared
  /// The bed is ready (found or prepared) and the impact starts.
  std::function<void(const World&)> on_bed_ready;
};

/// Runs `scene` with beds from `beds`, recording into `recorder`. Throws SceneError for a bad
/// scene, SimulationError for a run (or a bed) that became unstable, Cancelled when
/// control.steering.cancel is raised, and whatever the recorder throws (a full disk, say).
ImpactSummary RunJob(const Scene& scene, BedCache& beds, const JobControl& control,
                     RunRecorder& recorder);

}  // namespace dembuf
