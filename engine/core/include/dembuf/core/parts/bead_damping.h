// Damping of the beads' own motion, besides their contacts' (docs/model.md, "Particle
// damping"); off by default. On each degree of freedom of each bead (translation and rotation):
//   local (non-viscous, as PFC's): a force -alpha |F| sign(v), F the bead's unbalanced force
//     (contacts and gravity) and v its velocity; a torque -alpha |T| sign(w);
//   viscous background: a force -rate m v, a torque -rate I w.
// The projectile is not damped: its speed at the bed is the scene's. Both act in every kick,
// from the velocity before it: the two halves of a fused kick are then PFC's leapfrog step
// v(t + dt/2) = v(t - dt/2) + dt (F + F_d)/m.
#pragma once

#include <cmath>

#include "dembuf/core/parts/part.h"

namespace dembuf::dem {

/// Its parameters (WorldParams::bead_damping).
struct BeadDamping {
  double local_alpha = 0.0;         ///< 0 <= alpha < 1
  double viscous_rate_per_s = 0.0;  ///< >= 0; the speed of a free bead decays as exp(-rate t)
  bool Any() const { return local_alpha > 0.0 || viscous_rate_per_s > 0.0; }
};

struct LocalViscousDamping {
  static constexpr Stage kStage = Stage::kMotion;
  /// It sets a kick's acceleration (a motion stage has at most one such part).
  static constexpr bool kShapesAcceleration = true;
  using Params = BeadDamping;
  template <class World>
  static const Params& ParamsOf(const World& w) {
    return w.bead_damping;
  }
  template <class World>
  static bool On(const World& w) {
    return ParamsOf(w).Any();
  }

  /// The sign of a velocity component: 0 for a bead at rest in it (PFC's convention), so that
  /// local damping neither pushes a resting bead nor needs a branch.
  static DEMBUF_ALWAYS_INLINE double Sign(double v) {
    return static_cast<double>(v > 0.0) - static_cast<double>(v < 0.0);
  }

  /// One component's acceleration: the unbalanced force `f` (gravity in it), the velocity `v`
  /// before the kick, the inverse mass and the mass (for a turn: torque, angular velocity,
  /// inverse inertia and inertia).
  static DEMBUF_ALWAYS_INLINE double Acceleration(double f, double v, double inv_m, double m,
                                                  const BeadDamping& d) {
    return inv_m * (f - d.local_alpha * std::abs(f) * Sign(v) - d.viscous_rate_per_s * m * v);
  }
};

}  // namespace dembuf::dem
