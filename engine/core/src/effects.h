// The effects a world may have, as compile-time flags. The force and integration kernels are
// templates on a set of them, and a step picks the instance once (WithEffects), so a scene
// without an effect pays nothing for it: no branch in the loops, no history, no torque.
#pragma once

namespace dembuf::dem::detail {

template <bool kFrictionOn, bool kRollingOn>
struct Effects {
  /// Tangential springs with history and the Coulomb cap (mu > 0).
  static constexpr bool kFriction = kFrictionOn;
  /// Rolling resistance: a torque against the relative rolling of two bodies (mu_r > 0).
  static constexpr bool kRolling = kRollingOn;
  /// Beads turn (they get torques) only with one of the two.
  static constexpr bool kRotate = kFriction || kRolling;
};

/// Calls f(Effects<...>{}) with the instance for these run-time switches.
template <class F>
decltype(auto) WithEffects(bool friction, bool rolling, F&& f) {
  if (friction) {
    if (rolling) return f(Effects<true, true>{});
    return f(Effects<true, false>{});
  }
  if (rolling) return f(Effects<false, true>{});
  return f(Effects<false, false>{});
}

}  // namespace dembuf::dem::detail
