// One progress over a whole job: its bed stages and its impact, each weighted by its predicted
// time (resource_estimate.h), so that a job's fraction grows from 0 to 1 once, instead of
// starting again at each bed stage, and one time left can be told from it.
#pragma once

#include <string>
#include <vector>

#include "dembuf/study/bed/bed.h"
#include "dembuf/study/impact/impact.h"
#include "dembuf/study/run/resource_estimate.h"

namespace dembuf {

class WholeJobProgress {
 public:
  /// The job's stages from its estimate; the beds named in `cached` are ready and weigh
  /// nothing.
  WholeJobProgress(const ResourceEstimate& estimate, const std::vector<std::string>& cached = {});

  /// The whole job's fraction done while a bed stage reports `p`, and while the impact
  /// reports `p` (its stepped part: from its first report to its estimated end; the flight
  /// before it is computed). Never less than an earlier answer.
  double WhileBed(const BedProgress& p);
  double WhileImpact(const ImpactProgress& p);

 private:
  struct Part {
    std::string stage;  // "source", "cut", "friction", "import", "impact"
    double seconds;     // predicted, one thread
    double typical_s;   // the simulated time it typically takes
  };
  double Through(std::size_t part, double part_fraction);

  std::vector<Part> m_parts;
  double m_total = 0.0;
  double m_done = 0.0;        // the largest fraction told so far
  double m_impact_t0 = -1.0;  // the impact's first report's time
};

/// The estimate's stage ("source", "cut", "friction", "import") a bed progress report's stage
/// name belongs to ("settling (soft)", "relaxing the cut bed (locally)", ...).
std::string BedStageOf(const std::string& progress_stage);

}  // namespace dembuf
