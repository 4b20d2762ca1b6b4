// The contact law of docs/model.md section 2 (paper eqs. 1-5) from the materials: effective
// moduli and radii, and the constants of a kind of pair. The law's arithmetic is in its parts
// (parts/hertz_normal.h, parts/mindlin_tangential.h, parts/rolling_resistance.h), written
// once, component by component, because that is the form a vectorizing compiler needs.
//
//   Kn  = 4/3 E* sqrt(R*),  Ks = 8 G* sqrt(R*),  R* = RA RB / (RA + RB)  (R* = R for a wall)
#pragma once

#include <cmath>

#include "dembuf/core/parts/parts.h"
#include "dembuf/core/vec.h"

namespace dembuf::dem {

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

/// Constants of one kind of pair from its materials (PairParams, parts/pair_constants.h).
inline PairParams MakePairParams(const PairModuli& m, double damping_A_s, double friction) {
  return {4.0 / 3.0 * m.e_star, 8.0 * m.g_star, damping_A_s, friction};
}

/// R* = ra rb / (ra + rb) of two spheres (for a wall, R* = ra). Computed where it is needed
/// rather than stored per pair: the law's batches have the radii at hand, and a stored copy
/// would cost 8 bytes per neighbour entry.
DEMBUF_ALWAYS_INLINE double EffectiveRadius(double ra, double rb) {
  return ra * rb / (ra + rb);
}

/// The geometry of one contact, as vectors: `normal` points from the other body to this one;
/// `slip_velocity` is ContactLane's s.
struct ContactGeometry {
  Vec3 normal;
  double overlap;
  double approach_rate;
  Vec3 slip_velocity;
  double r_star;
};

/// Elastic energy stored in a contact: 2/5 Kn x^(5/2) + 1/2 Ks x^(1/2) |shear|^2.
inline double ContactElasticEnergy(double overlap, double r_star, const PairParams& p,
                                   const Vec3& shear) {
  return HertzNormal::ElasticEnergy(overlap, r_star, p) +
         MindlinTangential::ElasticEnergy(overlap, r_star, p, shear);
}

}  // namespace dembuf::dem
