// How runs that go at once share a machine's cores, the order a sweep starts them in, and the
// plan a sweep's dry run prints. The run queue (run_queue.h) applies ShareCores to the runs it
// has started, and PlanSchedule plays the same queue forward on the estimates, so the plan
// shows what the queue will do. Results do not depend on threads or order: only wall time does.
#pragma once

#include <cstddef>
#include <set>
#include <string>
#include <vector>

#include "dembuf/study/bed/bed.h"
#include "dembuf/study/run/resource_estimate.h"
#include "dembuf/study/sweep/sweep_plan.h"

namespace dembuf {

/// A running run's claim on the cores: the threads its present bed can feed (dem::ThreadsFedBy),
/// and how many runs wait for the bed it is preparing (0: none).
struct CoreClaim {
  int threads_max = 1;
  int waiting = 0;
};

/// Threads for each running run on `cores` cores: one each; then the free cores to the runs
/// that others wait for, in proportion to how many wait for each (a core at a time to the most
/// waiting per thread), each up to what its bed can feed; then the rest to the others in turn,
/// each up to what its bed can feed. Cores no run can feed stay free: a thread with too few
/// beads slows its team. Never more than `cores` in all unless more runs than cores are running.
std::vector<int> ShareCores(int cores, const std::vector<CoreClaim>& running);

/// What a run weighs: its source bed and one thread's seconds for each part.
struct RunLoad {
  bool known = false;       ///< false: nothing is known (the run may take every core)
  std::string source_hash;  ///< the source bed it needs ("" for none)
  double source_beads = 0;  ///< beads of that source bed
  double source_s = 0;      ///< one thread's seconds to prepare it (0: in the cache)
  double beads = 0;         ///< the largest bed of the rest of the run (its cut, its impact)
  double rest_s = 0;        ///< one thread's seconds for the rest of the run
};
/// The load of a run with estimate `estimate` whose source bed is `source_hash`; the beds
/// named in `cached` are ready and cost nothing.
RunLoad LoadOf(const ResourceEstimate& estimate, const std::string& source_hash,
               const std::vector<std::string>& cached = {});

/// The loads of a sweep's runs; beds in `beds` (when given) cost nothing. A run whose scene
/// cannot be estimated has a load not known.
std::vector<RunLoad> LoadsOf(const std::vector<SweepRun>& runs, BedCache* beds = nullptr);

/// The threads a run may use now: its source bed's while it prepares it, else its own bed's;
/// every core when its load is not known.
int ThreadsMax(const RunLoad& load, bool preparing_source, int cores);

/// The order a sweep starts its runs in: round robin over the source beds, so that the first
/// runs prepare every source bed at once, and within a source bed the heaviest first (longest
/// processing time first: the light runs come last and fill the cores as the others end).
std::vector<std::size_t> StartOrder(const std::vector<RunLoad>& runs);

/// The share of a step that does not gain from threads, assumed for the prediction: the
/// serial fraction (Karp-Flatt) of the 7,910-bead impact on two threads (docs/performance.md).
inline constexpr double kStepSerialFraction = 0.13;
/// The speedup of `threads` threads by Amdahl's law with kStepSerialFraction.
double PredictedSpeedup(int threads);

struct PlannedRun {
  std::size_t run = 0;           ///< index in the sweep
  bool prepares_source = false;  ///< it prepares its source bed; others wait for it
  double start_s = 0;
  double source_ready_s = 0;  ///< when the source bed it prepares is ready
  double end_s = 0;
  int threads_at_start = 1;
};
struct SchedulePlan {
  std::vector<PlannedRun> runs;  ///< in the order they start
  double wall_s = 0;
  double one_thread_s = 0;  ///< the work, in one thread's seconds
  int cores = 1;
};

/// What the run queue will do with `runs`, taken in `order`, on `cores` cores with `workers`
/// workers (0: one per core): the queue's rules (at most `cores` runs at once and one per
/// worker, a run whose source bed another run is preparing passed over, ShareCores) played
/// forward with the estimates' costs and PredictedSpeedup. Source beds with a zero source_s
/// are ready from the start.
SchedulePlan PlanSchedule(const std::vector<RunLoad>& runs, const std::vector<std::size_t>& order,
                          int cores, int workers = 0);

}  // namespace dembuf
