// Helpers for two-body collision tests: a world with the scene's contact constants and no
// gravity, and a recorder of overlap, force and contact times.
#pragma once

#include <cmath>
#include <optional>

#include "dembuf/core/simulation.h"
#include "dembuf/study/impact/impact.h"

namespace dembuf::test {

/// The scene's calibrated pair constants, in a large container far from everything, without
/// gravity, at time-step factor alpha.
inline dem::WorldParams IsolatedWorld(const Scene& scene, double alpha) {
  Scene s = scene;
  s.time.alpha = alpha;
  dem::WorldParams p = BuildWorld(s).params;
  p.gravity_m_s2 = 0.0;
  p.container = {1.0, 2.0};
  return p;
}

/// Two beads of radii r1 and r2 (density rho) approaching head-on along x at relative speed v
/// with zero total momentum, just apart, at height 1 m.
inline dem::Simulation HeadOnPair(const dem::WorldParams& p, double r1, double r2, double rho,
                                  double v) {
  dem::ParticleState beads;
  const double gap = 1e-7;
  beads.Add(dem::Vec3(-r1 - gap, 0, 1), r1, rho);
  beads.Add(dem::Vec3(r2 + gap, 0, 1), r2, rho);
  const double m1 = beads.mass[0], m2 = beads.mass[1];
  beads.velocity[0] = dem::Vec3(v * m2 / (m1 + m2), 0, 0);
  beads.velocity[1] = dem::Vec3(-v * m1 / (m1 + m2), 0, 0);
  return dem::Simulation(p, std::move(beads), std::nullopt);
}

/// What one contact did, from step-by-step samples of its overlap.
struct ContactRecord {
  double max_overlap = 0.0;
  double max_force = 0.0;
  double t_start = -1.0;  ///< overlap crossing zero, interpolated within the step
  double t_end = -1.0;
  double Duration() const { return t_end - t_start; }
};

/// Steps until the contact has ended (or max_steps), recording overlap(sim) and force(sim).
template <class Overlap, class Force>
ContactRecord RecordContact(dem::Simulation& sim, Overlap overlap, Force force, long max_steps) {
  ContactRecord rec;
  double prev_overlap = overlap(sim), prev_t = sim.time_s();
  for (long k = 0; k < max_steps; ++k) {
    sim.Step();
    const double ov = overlap(sim), t = sim.time_s();
    if (prev_overlap <= 0.0 && ov > 0.0 && rec.t_start < 0.0)
      rec.t_start = prev_t + (t - prev_t) * (-prev_overlap) / (ov - prev_overlap);
    if (ov > 0.0) {
      rec.max_overlap = std::max(rec.max_overlap, ov);
      rec.max_force = std::max(rec.max_force, force(sim));
    }
    if (prev_overlap > 0.0 && ov <= 0.0) {
      rec.t_end = prev_t + (t - prev_t) * prev_overlap / (prev_overlap - ov);
      break;
    }
    prev_overlap = ov;
    prev_t = t;
  }
  return rec;
}

/// Hertz's elastic impact of a reduced mass m* at speed v with stiffness Kn = 4/3 E* sqrt(R*):
///   x_max = (5 m* v^2 / (4 Kn))^(2/5),  F_max = Kn x_max^(3/2),
///   t_c   = 2 x_max / v * int_0^1 (1 - s^(5/2))^(-1/2) ds = 2.9432 x_max / v,
/// with the integral equal to (2/5) B(2/5, 1/2) = (2/5) Gamma(2/5) Gamma(1/2) / Gamma(9/10).
struct HertzImpact {
  double max_overlap, max_force, duration;
  HertzImpact(double kn, double reduced_mass, double v) {
    max_overlap = std::pow(1.25 * reduced_mass * v * v / kn, 0.4);
    max_force = kn * std::pow(max_overlap, 1.5);
    const double integral = 0.4 * std::tgamma(0.4) * std::tgamma(0.5) / std::tgamma(0.9);
    duration = 2.0 * max_overlap / v * integral;
  }
};

// An independent integration of m* x'' = -Kn x^(3/2) - A Kn x^(1/2) x' in SI units, by
// velocity Verlet with a tiny step (not the library's dimensionless RK4).
inline double FineStepRestitution(double A, double kn, double m, double v) {
  const double duration = 3.3 * std::pow(m * m / (kn * kn * v), 0.2);  // > Hertz time
  const double h = duration * 1e-6;
  double x = 0.0, u = v;  // overlap and its rate
  auto accel = [&](double xx, double uu) {
    if (xx <= 0.0) return 0.0;
    const double f = kn * std::sqrt(xx) * (xx + A * uu);
    return f > 0.0 ? -f / m : 0.0;
  };
  double a = accel(x, u);
  for (long k = 0; k < 100'000'000; ++k) {
    const double u_half = u + 0.5 * h * a;
    x += h * u_half;
    a = accel(x, u_half);
    u = u_half + 0.5 * h * a;
    if (x <= 0.0 && u < 0.0) return -u / v;
  }
  return 0.0;
}

}  // namespace dembuf::test
