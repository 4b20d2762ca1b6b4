// Friction (docs/model.md section 2, paper eqs. 2, 4 and 5): Mindlin's tangential spring with
// history, capped by Coulomb's law. On when a pair has friction (mu > 0).
//
//   Fs* = -Ks x^(1/2) xs,  |Fs| = min(|Fs*|, mu Fn),  Ks = 8 G* sqrt(R*)
//
// The history xs is turned into the current tangent plane with its length kept, advanced by
// s dt, and shortened while sliding so that |Fs*| = mu Fn. Both sides of each of the law's
// choices are computed and one is selected, as in a vector lane (no branch). About 55 flops and
// two square roots a contact.
#pragma once

#include "dembuf/core/parts/part.h"
#include "dembuf/core/vec.h"

namespace dembuf::dem {

struct MindlinTangential {
  static constexpr Stage kStage = Stage::kContact;
  static constexpr bool kTurnsBodies = true;
  static constexpr bool kReadsSlip = true;
  static constexpr bool kKeepsHistory = true;
  /// (A template: WorldParams holds the parts' parameters, so it is defined after them.)
  template <class World>
  static bool On(const World& w) {
    return w.sphere_pair.friction > 0.0 || w.sphere_wall.friction > 0.0 ||
           (w.species.count > 1 && w.species.AnyFriction());
  }

  /// The tangential force, added to the normal one; its torques -a (n x Ft) on both bodies
  /// (the first torques of the list: it sets them); the advanced history.
  static DEMBUF_ALWAYS_INLINE void Lane(const ContactLane& c, const ContactConstants& k,
                                        ContactResult& r) {
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
    hx = hx + c.sx * k.dt;
    hy = hy + c.sy * k.dt;
    hz = hz + c.sz * k.dt;
    // Mindlin spring, capped at mu Fn; while sliding the spring shortens to the cap.
    const double ks_x = k.pair.ks_per_sqrt_r * r.sqrt_rx;
    double tx = -ks_x * hx, ty = -ks_x * hy, tz = -ks_x * hz;
    const double cap = k.pair.friction * r.normal;
    const double ft2 = tx * tx + ty * ty + tz * tz;
    const bool slide = ft2 > cap * cap;
    const double shorten = cap / std::sqrt(ft2);
    tx = slide ? tx * shorten : tx;
    ty = slide ? ty * shorten : ty;
    tz = slide ? tz * shorten : tz;
    // (A contact slides only with a spring: without one, ft2 = 0.)
    r.hx = slide ? -tx / ks_x : hx;
    r.hy = slide ? -ty / ks_x : hy;
    r.hz = slide ? -tz / ks_x : hz;
    r.fx = r.fx + tx;
    r.fy = r.fy + ty;
    r.fz = r.fz + tz;
    const double mx = ny * tz - nz * ty, my = nz * tx - nx * tz, mz = nx * ty - ny * tx;
    r.tix = -c.ai * mx;
    r.tiy = -c.ai * my;
    r.tiz = -c.ai * mz;
    r.tjx = -c.aj * mx;
    r.tjy = -c.aj * my;
    r.tjz = -c.aj * mz;
  }

  /// The force of a stored spring, without advancing it (what a snapshot shows).
  static Vec3 StoredSpringForce(double overlap, double r_star, const PairParams& p,
                                const Vec3& shear) {
    return -(p.ks_per_sqrt_r * std::sqrt(r_star * overlap)) * shear;
  }

  /// The elastic energy of the spring: 1/2 Ks x^(1/2) |shear|^2.
  static double ElasticEnergy(double overlap, double r_star, const PairParams& p,
                              const Vec3& shear) {
    return 0.5 * p.ks_per_sqrt_r * std::sqrt(r_star * overlap) * shear.squaredNorm();
  }
};

}  // namespace dembuf::dem
