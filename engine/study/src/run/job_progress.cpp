#include "dembuf/study/run/job_progress.h"

#include <algorithm>

namespace dembuf {

std::string BedStageOf(const std::string& progress_stage) {
  if (progress_stage.find("cut") != std::string::npos) return "cut";
  if (progress_stage.find("friction") != std::string::npos) return "friction";
  if (progress_stage.find("imported") != std::string::npos) return "import";
  return "source";
}

WholeJobProgress::WholeJobProgress(const ResourceEstimate& estimate,
                                   const std::vector<std::string>& cached) {
  for (const StageEstimate& stage : estimate.stages) {
    if (std::find(cached.begin(), cached.end(), stage.hash) != cached.end()) continue;
    m_parts.push_back({stage.stage, estimate.StageSeconds(stage, 1), stage.typical_settle_s});
  }
  m_parts.push_back({"impact", estimate.ImpactSeconds(1), 0.0});
  for (const Part& part : m_parts) m_total += part.seconds;
}

double WholeJobProgress::Through(std::size_t part, double part_fraction) {
  double before = 0.0;
  for (std::size_t k = 0; k < part && k < m_parts.size(); ++k) before += m_parts[k].seconds;
  const double seconds = part < m_parts.size() ? m_parts[part].seconds : 0.0;
  const double fraction =
      m_total > 0.0 ? (before + std::clamp(part_fraction, 0.0, 1.0) * seconds) / m_total : 0.0;
  m_done = std::max(m_done, std::min(fraction, 1.0));
  return m_done;
}

double WholeJobProgress::WhileBed(const BedProgress& p) {
  const std::string stage = BedStageOf(p.stage);
  const auto part =
      std::find_if(m_parts.begin(), m_parts.end(), [&](const Part& x) { return x.stage == stage; });
  if (part == m_parts.end()) return m_done;  // a stage the estimate did not expect
  // The stage's simulated time against the time a bed typically takes, short of its end: a
  // bed that settles slowly waits at 95% of its stage rather than passing the next.
  const double typical = part->typical_s > 0.0 ? part->typical_s : p.t_max_s;
  const double within = typical > 0.0 ? std::min(0.95, p.t_s / typical) : 0.0;
  return Through(static_cast<std::size_t>(part - m_parts.begin()), within);
}

double WholeJobProgress::WhileImpact(const ImpactProgress& p) {
  if (m_impact_t0 < 0.0) m_impact_t0 = p.t_s;
  const double span = p.t_end_estimate_s - m_impact_t0;
  return Through(m_parts.size() - 1, span > 0.0 ? (p.t_s - m_impact_t0) / span : 0.0);
}

}  // namespace dembuf
