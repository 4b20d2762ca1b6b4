// The constants of one kind of pair (bead-bead, bead-wall, ...) that the contact law's parts
// read: Hertz's normal stiffness and damping (hertz_normal.h) and Mindlin's tangential
// stiffness and friction (mindlin_tangential.h). Kept together because every contact of a kind
// of pair has all four: the law's batches copy them once.
#pragma once

namespace dembuf::dem {

struct PairParams {
  double kn_per_sqrt_r;  ///< 4/3 E*: Kn = kn_per_sqrt_r * sqrt(R*)      (HertzNormal)
  double ks_per_sqrt_r;  ///< 8 G*:   Ks = ks_per_sqrt_r * sqrt(R*)      (MindlinTangential)
  double damping_A_s;    ///< A, Kuwabara-Kono's damping                 (HertzNormal)
  double friction;       ///< mu, the Coulomb cap of the tangential force (MindlinTangential)
};

}  // namespace dembuf::dem
