// Per-contact kinematics shared by every pair type: from two bodies' states to the law's
// ContactGeometry, and from the law's force to forces and torques on both bodies.
#pragma once

#include <cmath>

#include "dembuf/engine/contact_law.h"

namespace dembuf::detail {

/// Forces and torques of one contact on body i (and the torque on body j; its force is -force).
struct ContactOutcome {
  Vec3 force;
  Vec3 torque_i;
  Vec3 torque_j;
  double normal;  ///< normal force magnitude
};

/// Geometry of a contact with unit normal n (from j to i), given the relative velocity
/// v_rel = v_i - v_j and w_arm = r_i w_i + r_j w_j (surface speed from spin: the contact point
/// of i moves with v_i - r_i w_i x n, that of j with v_j + r_j w_j x n).
inline ContactGeometry MakeGeometry(const Vec3& n, double overlap, const Vec3& v_rel,
                                    const Vec3& w_arm, double sqrt_r_star) {
  const double approach = -v_rel.dot(n);
  return {n, overlap, approach, v_rel + approach * n - w_arm.cross(n), sqrt_r_star};
}

/// Applies the law to a contact of geometry c between sphere i (radius ri) and body j
/// (radius rj; a wall uses rj = 0, which gives it no torque).
template <bool kFriction>
inline ContactOutcome Resolve(const ContactGeometry& c, double ri, double rj, const PairParams& p,
                              double dt, Vec3& shear) {
  const ContactForce f = HertzMindlinForce<kFriction>(c, p, dt, shear);
  ContactOutcome out;
  out.normal = f.normal;
  if constexpr (kFriction) {
    out.force = f.normal * c.normal + f.tangential;
    const Vec3 arm = c.normal.cross(f.tangential);  // both torques are -r (n x Ft)
    out.torque_i = -ri * arm;
    out.torque_j = -rj * arm;
  } else {
    out.force = f.normal * c.normal;
    out.torque_i = out.torque_j = Vec3::Zero();
  }
  return out;
}

/// Elastic energy stored in a contact: 2/5 Kn x^(5/2) + 1/2 Ks x^(1/2) |shear|^2.
inline double ContactElasticEnergy(double overlap, double sqrt_r_star, const PairParams& p,
                                   const Vec3& shear) {
  const double sqrt_x = std::sqrt(overlap);
  return 0.4 * p.kn_per_sqrt_r * sqrt_r_star * overlap * overlap * sqrt_x +
         0.5 * p.ks_per_sqrt_r * sqrt_r_star * sqrt_x * shear.squaredNorm();
}

}  // namespace dembuf::detail
