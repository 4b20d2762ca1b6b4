// Rolling resistance (docs/model.md section 2; not in the paper's model): a constant
// directional torque mu_r R* Fn against the relative rolling of the two bodies, that is
// w_rel = w_this - w_other less its spin about n (twisting is not rolling). On when mu_r > 0.
//
// A torque that would reverse the rolling within one step of dt stops it instead, so that a
// body at rest stays at rest instead of rocking.
#pragma once

#include "dembuf/core/parts/part.h"

namespace dembuf::dem {

struct RollingResistance {
  static constexpr Stage kStage = Stage::kContact;
  static constexpr bool kTurnsBodies = true;
  static constexpr bool kReadsSpin = true;
  /// mu_r is the world's (WorldParams::rolling_friction), the same for every contact.
  template <class World>
  static bool On(const World& w) {
    return w.rolling_friction > 0.0;
  }

  /// Adds the torque on this body, and its opposite on the other, to the torques before it.
  static DEMBUF_ALWAYS_INLINE void Lane(const ContactLane& c, const ContactConstants& k,
                                        ContactResult& r) {
    const double along = c.wx * c.nx + c.wy * c.ny + c.wz * c.nz;
    const double rx = c.wx - along * c.nx, ry = c.wy - along * c.ny, rz = c.wz - along * c.nz;
    const double rate = std::sqrt(rx * rx + ry * ry + rz * rz);
    const double limit = k.rolling_friction * c.r_star * r.normal;
    const double stop = c.inertia * rate / k.dt;
    const double torque = stop < limit ? stop : limit;
    const double scale = rate > 0.0 ? -torque / rate : 0.0;  // no rolling, no torque
    const double tx = scale * rx, ty = scale * ry, tz = scale * rz;
    r.tix = r.tix + tx;
    r.tiy = r.tiy + ty;
    r.tiz = r.tiz + tz;
    r.tjx = r.tjx - tx;
    r.tjy = r.tjy - ty;
    r.tjz = r.tjz - tz;
  }
};

}  // namespace dembuf::dem
