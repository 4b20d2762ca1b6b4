// Per-contact kinematics shared by every pair type: from two bodies' states to the law's
// ContactGeometry, and from the law's force to forces and torques on both bodies.
#pragma once

#include <cmath>

#include "dembuf/core/contact_law.h"
#include "dembuf/core/particles.h"

namespace dembuf::dem::detail {

/// Forces and torques of one contact on body i (and the torque on body j; its force is -force).
struct ContactOutcome {
  Vec3 force;
  Vec3 torque_i;
  Vec3 torque_j;
  double normal;  ///< normal force magnitude
};

/// Geometry of a contact with unit normal n (from j to i), given the relative velocity
/// v_rel = v_i - v_j and w_arm = a_i w_i + a_j w_j, where a = r - overlap/2 are the lever arms
/// to the contact point in the middle of the overlap (it moves with v_i - a_i w_i x n on i and
/// v_j + a_j w_j x n on j). With these arms a pair conserves angular momentum exactly.
inline ContactGeometry MakeGeometry(const Vec3& n, double overlap, const Vec3& v_rel,
                                    const Vec3& w_arm, double r_star) {
  const double approach = -v_rel.dot(n);
  return {n, overlap, approach, v_rel + approach * n - w_arm.cross(n), r_star};
}

/// Lever arm from a sphere's centre to the contact point in the middle of the overlap.
inline double LeverArm(double radius, double overlap) {
  return radius - 0.5 * overlap;
}

/// What rolling resistance reads of a contact besides its geometry: the bodies' relative
/// angular velocity w_i - w_j (w_i for a wall), the pair's inertia 1 / (1/I_i + 1/I_j) (I_i for
/// a wall) and mu_r.
struct RollingPair {
  Vec3 w_rel = Vec3::Zero();
  double inertia = 0.0;
  double mu_r = 0.0;
};

/// Applies the law to a contact of geometry c between sphere i (lever arm ai) and body j
/// (lever arm aj; a wall uses aj = 0, which gives it no torque): the normal and tangential
/// forces and, with kRolling, the rolling resistance torque (on i, its opposite on j). The
/// contact loops' lanes (pair_batch.cpp) do the same operations in the same order.
template <bool kFriction, bool kRolling = false>
inline ContactOutcome Resolve(const ContactGeometry& c, double ai, double aj, const PairParams& p,
                              double dt, Vec3& shear, const RollingPair& rolling = {}) {
  const ContactForce f = HertzMindlinForce<kFriction>(c, p, dt, shear);
  ContactOutcome out;
  out.normal = f.normal;
  if constexpr (kFriction) {
    out.force = f.normal * c.normal + f.tangential;
    const Vec3 arm = c.normal.cross(f.tangential);  // both torques are -a (n x Ft)
    out.torque_i = -ai * arm;
    out.torque_j = -aj * arm;
  } else {
    out.force = f.normal * c.normal;
    out.torque_i = out.torque_j = Vec3::Zero();
  }
  if constexpr (kRolling) {
    const Vec3 torque = RollingResistanceTorque(c.normal, rolling.w_rel, f.normal, c.r_star,
                                                rolling.mu_r, rolling.inertia, dt);
    out.torque_i += torque;
    out.torque_j -= torque;
  }
  return out;
}

/// Side-wall contact of a sphere (centre x, radius r) inside the container: true when it
/// touches, with the overlap and the normal pointing from the wall into the sphere. The wall's
/// face acts on centres with 0 <= z <= height, its rim on those above (Container).
inline bool SideWallContact(const Container& box, const Vec3& x, double r, double& overlap,
                            Vec3& normal) {
  if (!box.TouchesSideWall(x.x(), x.y(), x.z(), r)) return false;
  const double rho = std::sqrt(x.x() * x.x() + x.y() * x.y());
  double nx, ny, nz;
  box.SideWallGeometry(x.x(), x.y(), x.z(), rho, r, overlap, nx, ny, nz);
  normal = Vec3(nx, ny, nz);
  return true;
}

}  // namespace dembuf::dem::detail
