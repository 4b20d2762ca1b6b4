// What a physics part is. Each mechanism of the model (Hertz normal force, Mindlin tangential
// spring, rolling resistance, the beads' own damping, ...) is one header in this folder: its
// parameters, when a world calls for it, and its arithmetic, in the form the engine's kernels
// run it. The list of parts (parts.h) drives the kernels: each is compiled once for every set
// of the parts of its stage that can be on, and a world picks its instance once, so that a
// part a world lacks costs nothing, not even a branch.
//
// A part is a struct with
//   kStage            the stage whose kernels run it (Stage below);
//   On(params)        whether a world calls for it (read once, when a simulation is made);
// the traits that are true of it (one it does not declare is false, detail:: below):
//   kAlwaysOn         the law's base, which every world has (it needs no On, and no kernel
//                     is compiled without it);
//   kTurnsBodies      it gives torques, so the beads must turn;
//   kReadsSlip        it reads the contact's slip velocity and tangential history;
//   kKeepsHistory     it advances that history (and the lists must keep it);
//   kReadsSpin        it reads the bodies' relative angular velocity and the pair's inertia;
//   kShapesAcceleration  (motion) it sets a kick's acceleration, from its Params (ParamsOf);
//   kFollowsTurningParts (motion) it is on exactly when a part that turns bodies is;
//   kPicksPairConstants  (contact) it picks each contact's PairParams by the bodies' species
//                     (it has no Lane: it changes what the others read);
// and its arithmetic: a contact part's Lane (ContactLane in, ContactResult added to), a motion
// part's Acceleration. The kernels ask for what the parts read and write (the k* traits), never
// for a part by name, so that a new part reading what the others read needs no kernel changed.
#pragma once

#include <cmath>

#include "dembuf/core/parts/pair_constants.h"

namespace dembuf::dem {

/// The stages of a step that parts act in.
enum class Stage {
  kContact,  ///< the force pass: a contact's forces and torques from the bodies' states
  kMotion,   ///< the kicks: a body's acceleration from its forces
};

/// Inlined even where the compiler would not: the vectorized loops need every part in them.
#if defined(__GNUC__)
#define DEMBUF_ALWAYS_INLINE inline __attribute__((always_inline))
#else
#define DEMBUF_ALWAYS_INLINE inline
#endif

namespace detail {
// A trait a part does not declare is false.
#define DEMBUF_PART_TRAIT(name)             \
  template <class P>                        \
  constexpr bool name() {                   \
    if constexpr (requires { P::k##name; }) \
      return P::k##name;                    \
    else                                    \
      return false;                         \
  }
DEMBUF_PART_TRAIT(AlwaysOn)
DEMBUF_PART_TRAIT(TurnsBodies)
DEMBUF_PART_TRAIT(ReadsSlip)
DEMBUF_PART_TRAIT(KeepsHistory)
DEMBUF_PART_TRAIT(ReadsSpin)
DEMBUF_PART_TRAIT(ShapesAcceleration)
DEMBUF_PART_TRAIT(FollowsTurningParts)
DEMBUF_PART_TRAIT(PicksPairConstants)
#undef DEMBUF_PART_TRAIT
}  // namespace detail

/// One contact at this instant, component by component (the form of a vector lane): n points
/// from the other body to this one; `overlap` > 0; `approach_rate` = d(overlap)/dt. The slip s
/// (this body's surface relative to the other's at the contact point) and the history h (the
/// tangential displacement so far) are set only for a part that reads them (kReadsSlip), the
/// relative spin w = w_this - w_other and the pair's inertia 1 / (1/I_this + 1/I_other) (I_this
/// for a wall) only for one that reads them (kReadsSpin). ai and aj are the lever arms from the
/// centres to the contact point (aj = 0 for a wall, which takes no torque).
struct ContactLane {
  double nx, ny, nz;
  double overlap, approach_rate, r_star;
  double sx, sy, sz;
  double hx, hy, hz;
  double wx, wy, wz, inertia;
  double ai, aj;
};

/// What the contact parts make of it, each adding its share in the list's order: the normal
/// force's magnitude (>= 0) and sqrt(R* overlap) (both stiffnesses go as it), the force on this
/// body, the torques on both bodies, and the advanced history.
struct ContactResult {
  double sqrt_rx = 0.0;
  double normal = 0.0;
  double fx = 0.0, fy = 0.0, fz = 0.0;
  double tix = 0.0, tiy = 0.0, tiz = 0.0;
  double tjx = 0.0, tjy = 0.0, tjz = 0.0;
  double hx = 0.0, hy = 0.0, hz = 0.0;
};

/// The constants a contact part reads besides the contact: the pair's (bead-bead or
/// bead-wall), the world's rolling resistance and the time step.
struct ContactConstants {
  PairParams pair;
  double rolling_friction;
  double dt;
};

}  // namespace dembuf::dem
