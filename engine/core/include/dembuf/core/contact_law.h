// The contact law of docs/model.md section 2 (paper eqs. 1-5): Hertz normal force with
// Kuwabara-Kono nonlinear damping, Mindlin tangential spring with history and a Coulomb cap.
//
//   Fn  = Kn xn^(3/2) + A Kn xn^(1/2) dxn/dt,  clamped at 0 (contacts never pull)
//   Fs* = -Ks xn^(1/2) xs,  |Fs| = min(|Fs*|, mu Fn)
//   Kn  = 4/3 E* sqrt(R*),  Ks = 8 G* sqrt(R*),  R* = RA RB / (RA + RB)  (R* = R for a wall)
//
// The law is written once, component by component (ApplyContactLaw), because that is the form
// a vectorizing compiler needs: the batches of bead pairs and wall contacts
// (engine/core/src/pair_batch.cpp) call it per vector lane, and every other contact (projectile,
// snapshots) through the Vec3 form HertzMindlinForce, which unpacks into it. The elastic
// energy and the force of a stored spring (for snapshots) are here too.
#pragma once

#include <algorithm>
#include <cmath>

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

/// Inlined even where the compiler would not: the vectorized batches need the law in the loop.
#if defined(__GNUC__)
#define DEMBUF_ALWAYS_INLINE inline __attribute__((always_inline))
#else
#define DEMBUF_ALWAYS_INLINE inline
#endif

/// R* = ra rb / (ra + rb) of two spheres (for a wall, R* = ra). Computed where it is needed
/// rather than stored per pair: the law's batches have the radii at hand, and a stored copy
/// would cost 8 bytes per neighbour entry.
DEMBUF_ALWAYS_INLINE double EffectiveRadius(double ra, double rb) {
  return ra * rb / (ra + rb);
}

/// One contact at this instant, component by component. n points from the other body to this
/// one; `overlap` > 0; `approach_rate` = d(overlap)/dt; s is the tangential velocity of this
/// body's surface relative to the other's at the contact point; h the tangential displacement
/// accumulated so far (the contact's history). s and h are read only with friction.
struct ContactLawInput {
  double nx, ny, nz;
  double overlap, approach_rate, r_star;
  double sx, sy, sz;
  double hx, hy, hz;
};

/// What the law gives: the normal force magnitude (>= 0), the tangential force on this body
/// and the advanced history (both zero without friction).
struct ContactLawOutput {
  double normal;
  double tx, ty, tz;
  double hx, hy, hz;
};

/// The law. The history is turned into the current tangent plane with its length kept,
/// advanced by s dt, and shortened while sliding so that |Fs*| = mu Fn. Both sides of each of
/// the law's choices are computed and one is selected, as in a vector lane (no branch).
/// Cost: about 60 flops and three square roots per contact with friction, 6 and one without.
template <bool kFriction>
DEMBUF_ALWAYS_INLINE ContactLawOutput ApplyContactLaw(const ContactLawInput& c, const PairParams& p,
                                                      double dt) {
  ContactLawOutput out{};
  const double sqrt_rx = std::sqrt(c.r_star * c.overlap);  // both stiffnesses go as sqrt(R* x)
  const double f = p.kn_per_sqrt_r * sqrt_rx * (c.overlap + p.damping_A_s * c.approach_rate);
  out.normal = f > 0.0 ? f : 0.0;  // contacts never pull
  if constexpr (kFriction) {
    const double nx = c.nx, ny = c.ny, nz = c.nz;
    // Keep the history in the tangent plane as the contact rolls: drop its normal part and
    // restore its length, so that rotating the pair does not create or destroy stored shear.
    double hx = c.hx, hy = c.hy, hz = c.hz;
    const double old_norm2 = hx * hx + hy * hy + hz * hz;
    const double along = hx * nx + hy * ny + hz * nz;
    const double px = hx - along * nx, py = hy - along * ny, pz = hz - along * nz;
    const double new_norm2 = px * px + py * py + pz * pz;
    const bool turn = old_norm2 > 0.0;
    const double rescale = new_norm2 > 0.0 ? std::sqrt(old_norm2 / new_norm2) : 1.0;
    hx = turn ? px * rescale : hx;
    hy = turn ? py * rescale : hy;
    hz = turn ? pz * rescale : hz;
    hx = hx + c.sx * dt;
    hy = hy + c.sy * dt;
    hz = hz + c.sz * dt;
    // Mindlin spring, capped at mu Fn; while sliding the spring shortens to the cap.
    const double ks_x = p.ks_per_sqrt_r * sqrt_rx;
    double tx = -ks_x * hx, ty = -ks_x * hy, tz = -ks_x * hz;
    const double cap = p.friction * out.normal;
    const double ft2 = tx * tx + ty * ty + tz * tz;
    const bool slide = ft2 > cap * cap;
    const double shorten = cap / std::sqrt(ft2);
    tx = slide ? tx * shorten : tx;
    ty = slide ? ty * shorten : ty;
    tz = slide ? tz * shorten : tz;
    // (A contact slides only with a spring: without one, ft2 = 0.)
    out.hx = slide ? -tx / ks_x : hx;
    out.hy = slide ? -ty / ks_x : hy;
    out.hz = slide ? -tz / ks_x : hz;
    out.tx = tx;
    out.ty = ty;
    out.tz = tz;
  }
  return out;
}

/// The geometry of one contact, as vectors: `normal` points from the other body to this one;
/// `slip_velocity` is ContactLawInput's s.
struct ContactGeometry {
  Vec3 normal;
  double overlap;
  double approach_rate;
  Vec3 slip_velocity;
  double r_star;
};

/// Force on this body: the normal magnitude (>= 0) and the tangential vector.
struct ContactForce {
  double normal;
  Vec3 tangential;
};

/// The law in vector form; `shear` is the contact's history, advanced in place.
template <bool kFriction>
inline ContactForce HertzMindlinForce(const ContactGeometry& c, const PairParams& p, double dt,
                                      Vec3& shear) {
  const ContactLawInput in{c.normal.x(),        c.normal.y(),        c.normal.z(),
                           c.overlap,           c.approach_rate,     c.r_star,
                           c.slip_velocity.x(), c.slip_velocity.y(), c.slip_velocity.z(),
                           shear.x(),           shear.y(),           shear.z()};
  const ContactLawOutput out = ApplyContactLaw<kFriction>(in, p, dt);
  if constexpr (kFriction) shear = Vec3(out.hx, out.hy, out.hz);
  return {out.normal, Vec3(out.tx, out.ty, out.tz)};
}

/// Rolling resistance (docs/model.md section 2; off unless mu_r > 0), as a constant directional
/// torque: mu_r R* Fn against the relative rolling of the two bodies, that is w_rel = w_this -
/// w_other less its spin about n (twisting is not rolling). A torque that would reverse the
/// rolling within one step of dt stops it instead, so that a body at rest stays at rest
/// instead of rocking; `inertia` is the pair's 1 / (1/I_this + 1/I_other) (I_this for a wall).
/// The law's third part, in component form like ApplyContactLaw: the contact loops resolve it
/// in the same lanes, and the torque on this body is added to the tangential force's (the
/// other body gets its opposite).
struct RollingInput {
  double nx, ny, nz;  ///< the contact's unit normal
  double wx, wy, wz;  ///< w_rel = w_this - w_other
  double normal;      ///< the normal force's magnitude, from ApplyContactLaw
  double r_star;
  double inertia;
};
struct RollingOutput {
  double tx, ty, tz;  ///< the torque on this body
};
DEMBUF_ALWAYS_INLINE RollingOutput ApplyRollingResistance(const RollingInput& c, double mu_r,
                                                          double dt) {
  const double along = c.wx * c.nx + c.wy * c.ny + c.wz * c.nz;
  const double rx = c.wx - along * c.nx, ry = c.wy - along * c.ny, rz = c.wz - along * c.nz;
  const double rate = std::sqrt(rx * rx + ry * ry + rz * rz);
  const double limit = mu_r * c.r_star * c.normal;
  const double stop = c.inertia * rate / dt;
  const double torque = stop < limit ? stop : limit;
  const double scale = rate > 0.0 ? -torque / rate : 0.0;  // no rolling, no torque
  return {scale * rx, scale * ry, scale * rz};
}

/// The same in vector form: the torque on this body.
inline Vec3 RollingResistanceTorque(const Vec3& n, const Vec3& w_rel, double normal, double r_star,
                                    double mu_r, double inertia, double dt) {
  const RollingOutput out = ApplyRollingResistance(
      {n.x(), n.y(), n.z(), w_rel.x(), w_rel.y(), w_rel.z(), normal, r_star, inertia}, mu_r, dt);
  return Vec3(out.tx, out.ty, out.tz);
}

/// Normal force magnitude alone (eq. 1 with the clamp).
inline double HertzNormalForce(double overlap, double approach_rate, double r_star,
                               const PairParams& p) {
  ContactLawInput in{};
  in.overlap = overlap;
  in.approach_rate = approach_rate;
  in.r_star = r_star;
  return ApplyContactLaw<false>(in, p, 0.0).normal;
}

/// The force of a stored tangential spring, without advancing it (what a snapshot shows).
inline Vec3 StoredSpringForce(double overlap, double r_star, const PairParams& p,
                              const Vec3& shear) {
  return -(p.ks_per_sqrt_r * std::sqrt(r_star * overlap)) * shear;
}

/// Elastic energy stored in a contact: 2/5 Kn x^(5/2) + 1/2 Ks x^(1/2) |shear|^2.
inline double ContactElasticEnergy(double overlap, double r_star, const PairParams& p,
                                   const Vec3& shear) {
  const double sqrt_rx = std::sqrt(r_star * overlap);
  return 0.4 * p.kn_per_sqrt_r * sqrt_rx * overlap * overlap +
         0.5 * p.ks_per_sqrt_r * sqrt_rx * shear.squaredNorm();
}

}  // namespace dembuf::dem
