// The check stage of a step: what the passes recorded (StepConditions) turned into a stop with
// the reason and what to change, or into the observables' largest overlap.
#include <cmath>
#include <sstream>
#include <string>

#include "dembuf/core/errors.h"
#include "simulation_state.h"

namespace dembuf::dem {

namespace {

// An overlap of this fraction of the smaller radius leaves no sensible contact geometry (the
// centres nearly meet): the run is unstable. Large but smaller overlaps can be genuine in this
// model: a bead pinched between the projectile and the plate carries kilonewtons and Hertz
// then gives overlaps of 30-80% of its radius (glass would break; the model has no breakage).
// Those are reported (StepObservables::max_overlap_ratio), not refused.
constexpr double kMaxOverlapRatio = 0.9;

std::string Describe(BodyId id) {
  switch (id) {
    case kPlate:
      return "the plate";
    case kSideWall:
      return "the side wall";
    case kProjectile:
      return "the projectile";
    default:
      return "bead " + std::to_string(id);
  }
}

[[noreturn]] void Fail(const std::string& what, std::int64_t step, double t) {
  std::ostringstream msg;
  msg << "simulation unstable at step " << step << " (t = " << t << " s): " << what;
  throw SimulationError(msg.str(), step, t);
}

}  // namespace

void Simulation::CheckConditions() {
  detail::StepConditions& c = m_impl->conditions;
  if (c.nonfinite_bead >= 0)
    Fail("bead " + std::to_string(c.nonfinite_bead) + " has a non-finite position or velocity",
         m_steps, m_time_s);
  if (c.projectile_bad)
    Fail("the projectile has a non-finite position or velocity", m_steps, m_time_s);
  if (c.escaped_bead >= 0) {
    const Vec3& x = m_beads.position[c.escaped_bead];
    std::ostringstream what;
    what << "bead " << c.escaped_bead << " left the container (x, y, z = " << x.x() << ", " << x.y()
         << ", " << x.z() << " m; wall radius " << m_params.container.radius_m << " m, height "
         << m_params.container.height_m << " m)";
    const double rho = std::hypot(x.x(), x.y());
    // A bead that came over the rim is caught the step its centre falls below it, or lands
    // farther out than a step through the wall would take it.
    const double diameter = 2.0 * m_beads.radius[c.escaped_bead];
    const bool over_rim = x.z() > m_params.container.height_m - diameter ||
                          rho > m_params.container.radius_m + diameter;
    if (x.z() < 0.0)
      what << ": through the plate; the time step is too large (lower time.alpha)";
    else if (over_rim)
      what << ": thrown over the rim and fallen outside (raise cylinder.height_m)";
    else
      what << ": through the side wall; the time step is too large (lower time.alpha)";
    Fail(what.str(), m_steps, m_time_s);
  }
  m_observables.max_overlap_ratio = std::max(m_observables.max_overlap_ratio, c.max_overlap_ratio);
  if (c.max_overlap_ratio > kMaxOverlapRatio) {
    std::ostringstream what;
    what << "overlap of " << Describe(c.overlap_a) << " and " << Describe(c.overlap_b)
         << " reached " << c.max_overlap_ratio * 100.0 << "% of the smaller radius (limit "
         << kMaxOverlapRatio * 100.0
         << "%): the time step is too large for the speeds in this scene (lower time.alpha)";
    Fail(what.str(), m_steps, m_time_s);
  }
  c = detail::StepConditions{};
}

}  // namespace dembuf::dem
