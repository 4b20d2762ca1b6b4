// The law's base (docs/model.md section 2, paper eqs. 1 and 3): the Hertz normal force with
// Kuwabara-Kono nonlinear damping, which every contact has.
//
//   Fn = Kn x^(3/2) + A Kn x^(1/2) dx/dt,  clamped at 0 (contacts never pull),
//   Kn = 4/3 E* sqrt(R*)
#pragma once

#include "dembuf/core/parts/part.h"
#include "dembuf/core/vec.h"

namespace dembuf::dem {

struct HertzNormal {
  static constexpr Stage kStage = Stage::kContact;
  static constexpr bool kAlwaysOn = true;
  /// The normal force along n: the first part of the list, it sets what the others add to.
  /// 6 flops and one square root.
  static DEMBUF_ALWAYS_INLINE void Lane(const ContactLane& c, const ContactConstants& k,
                                        ContactResult& r) {
    r.sqrt_rx = std::sqrt(c.r_star * c.overlap);
    const double f =
        k.pair.kn_per_sqrt_r * r.sqrt_rx * (c.overlap + k.pair.damping_A_s * c.approach_rate);
    r.normal = f > 0.0 ? f : 0.0;  // contacts never pull
    r.fx = r.normal * c.nx;
    r.fy = r.normal * c.ny;
    r.fz = r.normal * c.nz;
  }

  /// The normal force's magnitude alone (what a snapshot shows), as Lane computes it.
  static double Force(double overlap, double approach_rate, double r_star, const PairParams& p) {
    ContactLane c{};
    c.overlap = overlap;
    c.approach_rate = approach_rate;
    c.r_star = r_star;
    ContactResult r;
    Lane(c, {p, 0.0, 0.0}, r);
    return r.normal;
  }

  /// The elastic energy of the normal spring: 2/5 Kn x^(5/2).
  static double ElasticEnergy(double overlap, double r_star, const PairParams& p) {
    return 0.4 * p.kn_per_sqrt_r * std::sqrt(r_star * overlap) * overlap * overlap;
  }
};

}  // namespace dembuf::dem
