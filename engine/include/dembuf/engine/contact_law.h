// The contact law of docs/model.md section 2 (paper eqs. 1-5): Hertz normal force with
// Kuwabara-Kono nonlinear damping, Mindlin tangential spring with history and a Coulomb cap.
//
//   Fn  = Kn xn^(3/2) + A Kn xn^(1/2) dxn/dt,  clamped at 0 (contacts never pull)
//   Fs* = -Ks xn^(1/2) xs,  |Fs| = min(|Fs*|, mu Fn)
//   Kn  = 4/3 E* sqrt(R*),  Ks = 8 G* sqrt(R*),  R* = RA RB / (RA + RB)  (R* = R for a wall)
//
// How to add a law: write a Params struct of pair constants and a force function of the same
// shape as HertzMindlinForce below; the kernels in contact_kernels.h call it per contact. Bead
// pairs, the bulk of the work, use a vectorized copy of the law (engine/src/pair_batch.cpp);
// tests/engine/pair_batch_test.cpp checks that the two give the same bits.
#pragma once

#include <algorithm>
#include <cmath>

#include "dembuf/engine/vec.h"

namespace dembuf {

/// Elastic constants of one material.
struct Elastic {
  double youngs_modulus_Pa;
  double poisson_ratio;
  double ShearModulus() const { return youngs_modulus_Pa / (2.0 * (1.0 + poisson_ratio)); }
};

/// Which effective shear modulus the tangential stiffness uses.
enum class ShearStiffness {
  kPaper,    ///< 1/G* = (1-nu1)/G1 + (1-nu2)/G2: G/(2(1-nu)) for a pair of one material
  kMindlin,  ///< 1/G* = (2-nu1)/G1 + (2-nu2)/G2: G/(2(2-nu)), Mindlin's theory
};

/// Effective moduli of a pair of materials: 1/E* = (1-nu1^2)/E1 + (1-nu2^2)/E2.
struct PairModuli {
  double e_star;
  double g_star;
};

inline PairModuli EffectiveModuli(const Elastic& a, const Elastic& b, ShearStiffness shear) {
  double inv_e = (1.0 - a.poisson_ratio * a.poisson_ratio) / a.youngs_modulus_Pa +
                 (1.0 - b.poisson_ratio * b.poisson_ratio) / b.youngs_modulus_Pa;
  double shift = shear == ShearStiffness::kPaper ? 1.0 : 2.0;
  double inv_g =
      (shift - a.poisson_ratio) / a.ShearModulus() + (shift - b.poisson_ratio) / b.ShearModulus();
  return {1.0 / inv_e, 1.0 / inv_g};
}

/// Constants of one kind of pair (bead-bead, bead-wall, ...): everything but the radii.
struct PairParams {
  double kn_per_sqrt_r;  ///< 4/3 E*: Kn = kn_per_sqrt_r * sqrt(R*)
  double ks_per_sqrt_r;  ///< 8 G*:   Ks = ks_per_sqrt_r * sqrt(R*)
  double damping_A_s;    ///< A
  double friction;       ///< mu
};

inline PairParams MakePairParams(const PairModuli& m, double damping_A_s, double friction) {
  return {4.0 / 3.0 * m.e_star, 8.0 * m.g_star, damping_A_s, friction};
}

/// The geometry of one contact at this instant. `normal` points from the other body to this
/// one; `overlap` > 0; `approach_rate` = d(overlap)/dt; `slip_velocity` is the tangential
/// velocity of this body's surface relative to the other's at the contact point.
struct ContactGeometry {
  Vec3 normal;
  double overlap;
  double approach_rate;
  Vec3 slip_velocity;
  double sqrt_r_star;
};

/// Force on this body: the normal magnitude (>= 0) and the tangential vector.
struct ContactForce {
  double normal;
  Vec3 tangential;
};

/// Normal force magnitude (eq. 1 with the clamp).
inline double HertzNormalForce(double overlap, double approach_rate, double kn, double damping) {
  double sqrt_x = std::sqrt(overlap);
  double f = kn * sqrt_x * (overlap + damping * approach_rate);
  return f > 0.0 ? f : 0.0;
}

/// The complete law. `shear` is the accumulated tangential displacement (the contact's
/// history); it is rotated into the current tangent plane, advanced by slip * dt and
/// truncated while sliding so that |Fs*| = mu Fn.
/// Cost: about 60 flops and one sqrt per contact with friction, 12 without.
template <bool kFriction>
inline ContactForce HertzMindlinForce(const ContactGeometry& c, const PairParams& p, double dt,
                                      Vec3& shear) {
  const double fn =
      HertzNormalForce(c.overlap, c.approach_rate, p.kn_per_sqrt_r * c.sqrt_r_star, p.damping_A_s);
  if constexpr (!kFriction) {
    return {fn, Vec3::Zero()};
  } else {
    // Keep the history in the tangent plane as the contact rolls: drop its normal part and
    // restore its length, so that rotating the pair does not create or destroy stored shear.
    const double old_norm2 = shear.squaredNorm();
    if (old_norm2 > 0.0) {
      shear -= shear.dot(c.normal) * c.normal;
      const double new_norm2 = shear.squaredNorm();
      if (new_norm2 > 0.0) shear *= std::sqrt(old_norm2 / new_norm2);
    }
    shear += c.slip_velocity * dt;
    const double ks_x = p.ks_per_sqrt_r * c.sqrt_r_star * std::sqrt(c.overlap);
    Vec3 ft = -ks_x * shear;
    const double cap = p.friction * fn;
    const double ft2 = ft.squaredNorm();
    if (ft2 > cap * cap) {
      ft *= cap / std::sqrt(ft2);
      // Sliding: shorten the spring to what the Coulomb limit supports.
      shear = ks_x > 0.0 ? Vec3(-ft / ks_x) : Vec3::Zero();
    }
    return {fn, ft};
  }
}

}  // namespace dembuf
