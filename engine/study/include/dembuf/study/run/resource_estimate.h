// What a run will cost, computed from its validated scene before anything is allocated or
// stepped: beads, time steps, samples, bytes written and peak memory. `dembuf run`, `sweep`
// and the daemon check it against limits before doing the work, and `--dry-run` prints it.
//
// Counts of work are upper bounds: a bed's settling is counted as if every stage ran until
// bed.max_settle_s, and an automatic end as if the whole impact window ran. The predicted
// wall time instead uses typical settling times, from the measured cost of a bead-step.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "dembuf/study/scene/scene.h"

namespace dembuf {

/// One bed stage a run may have to prepare (none when its bed is cached).
struct StageEstimate {
  std::string stage;              ///< "source", "cut", "friction" or "import"
  std::string hash;               ///< the bed's hash (its name in a bed cache)
  double beads = 0.0;             ///< beads settled in this stage
  double steps_max = 0.0;         ///< time steps if it settles for bed.max_settle_s
  double typical_settle_s = 0.0;  ///< simulated time a typical bed needs (for the prediction)
  double step_factor = 1.0;       ///< its time step over the impact's (soft settling)
};

struct ResourceEstimate {
  double dt_s = 0.0;
  std::vector<StageEstimate> stages;  ///< in the order they are prepared
  double impact_beads = 0.0;          ///< beads during the impact
  double flight_time_s = 0.0;         ///< the projectile's free flight (computed, not stepped)
  double impact_steps_max = 0.0;      ///< steps from the end of the flight to the end
  double samples_max = 0.0;           ///< force samples written (at most one a step)
  double snapshots = 0.0;             ///< snapshots written
  double animation_frames = 0.0;      ///< animation frames written (output.animation_interval_s)
  double output_bytes_max = 0.0;      ///< the files of a local run
  double memory_bytes_max = 0.0;      ///< the run's peak memory (the daemon's per job)

  /// The largest bed a stage or the impact holds.
  double MaxBeads() const;
  /// Time steps and bead-steps of the stages not yet prepared (`skip` lists the hashes of
  /// prepared beds) and the impact, bounds.
  double StepsMax(const std::vector<std::string>& skip = {}) const;
  double BeadStepsMax(const std::vector<std::string>& skip = {}) const;
  /// Predicted wall time on `threads` engine threads, with typical settling times.
  double PredictedSeconds(int threads, const std::vector<std::string>& skip = {}) const;
  /// The same for one stage, and for the impact alone.
  double StageSeconds(const StageEstimate& stage, int threads) const;
  double ImpactSeconds(int threads) const;
};

/// The estimate for a validated scene. Reads an imported bed file (bounded in size) for its
/// bead count and smallest radius. Throws SceneError for a scene it cannot estimate.
ResourceEstimate EstimateResources(const Scene& scene);

/// What one run may cost; 0 means no limit.
struct ResourceLimits {
  double beads = 0.0;
  double steps = 0.0;
  double bead_steps = 0.0;
  double samples = 0.0;
  double output_bytes = 0.0;
  double memory_bytes = 0.0;
};

/// The estimate passed a limit. `field` is the scene field to change; the message gives the
/// estimate, the limit and what to change.
class ResourceError : public std::runtime_error {
 public:
  ResourceError(std::string field, const std::string& message)
      : std::runtime_error(field + ": " + message), m_field(std::move(field)) {}
  const std::string& field() const { return m_field; }

 private:
  std::string m_field;
};

/// Throws ResourceError for the first limit the estimate passes (beads, steps, bead-steps,
/// samples, output, memory). `who` says whose limit it is ("this server's", "this machine's").
void CheckResources(const ResourceEstimate& estimate, const ResourceLimits& limits,
                    const Scene& scene, const std::string& who);

/// The estimate as lines of text (for --dry-run); `cached` lists the hashes of beds ready in
/// the cache, `threads` the engine threads of the prediction.
std::string DescribeEstimate(const ResourceEstimate& estimate,
                             const std::vector<std::string>& cached, int threads);

/// 1.5 kB, 3.2 MB, 4.1 GB: bytes for people.
std::string HumanBytes(double bytes);
/// 42 s, 3.5 min, 2.1 h: seconds for people.
std::string HumanSeconds(double seconds);

}  // namespace dembuf
