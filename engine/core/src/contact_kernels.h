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

/// What the parts that read spin (kReadsSpin) read of a contact besides its geometry: the
/// bodies' relative angular velocity w_i - w_j (w_i for a wall) and the pair's inertia
/// 1 / (1/I_i + 1/I_j) (I_i for a wall).
struct SpinPair {
  Vec3 w_rel = Vec3::Zero();
  double inertia = 0.0;
};

/// Applies the contact parts of E to a contact of geometry c between sphere i (lever arm ai)
/// and body j (lever arm aj; a wall uses aj = 0, which gives it no torque): the contact in
/// ContactLane's form, the parts' arithmetic (ResolveContact, the one copy the force pass's
/// lanes run too), and the forces and torques as vectors. `shear` is the contact's history,
/// advanced in place.
template <class E>
inline ContactOutcome Resolve(const ContactGeometry& c, double ai, double aj,
                              const ContactConstants& constants, Vec3& shear,
                              const SpinPair& spin = {}) {
  ContactLane lane{};
  lane.nx = c.normal.x();
  lane.ny = c.normal.y();
  lane.nz = c.normal.z();
  lane.overlap = c.overlap;
  lane.approach_rate = c.approach_rate;
  lane.r_star = c.r_star;
  if constexpr (E::kSlip) {
    lane.sx = c.slip_velocity.x();
    lane.sy = c.slip_velocity.y();
    lane.sz = c.slip_velocity.z();
    lane.hx = shear.x();
    lane.hy = shear.y();
    lane.hz = shear.z();
  }
  if constexpr (E::kSpin) {
    lane.wx = spin.w_rel.x();
    lane.wy = spin.w_rel.y();
    lane.wz = spin.w_rel.z();
    lane.inertia = spin.inertia;
  }
  lane.ai = ai;
  lane.aj = aj;
  const ContactResult r = ResolveContact<E>(lane, constants);
  if constexpr (E::kHistory) shear = Vec3(r.hx, r.hy, r.hz);
  return {Vec3(r.fx, r.fy, r.fz), Vec3(r.tix, r.tiy, r.tiz), Vec3(r.tjx, r.tjy, r.tjz), r.normal};
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
