#include "integrator.h"

#include <omp.h>

#include <algorithm>
#include <cmath>

#include "vector_copies.h"

namespace dembuf::dem::detail {

namespace {

// The per-bead arrays the integrator works on, as components (x y z x y z ...), so that its
// loops vectorize.
struct Kinematics {
  double* position;
  double* velocity;
  double* angular_velocity;
  double* force;
  double* torque;
  const double* radius;
  const double* inv_mass;
  const double* mass;  // for the moment of inertia
};

Kinematics BeadKinematics(ParticleState& b) {
  return {Components(b.position), Components(b.velocity), Components(b.angular_velocity),
          Components(b.force),    Components(b.torque),   b.radius.data(),
          b.inv_mass.data(),      b.mass.data()};
}

// A bead's velocity after its kicks (the drift's input).
struct Velocity {
  double x, y, z;
};

// The sign of a velocity component: 0 for a bead at rest in it (PFC's convention), so that local
// damping neither pushes a resting bead nor needs a branch.
DEMBUF_ALWAYS_INLINE double Sign(double v) {
  return static_cast<double>(v > 0.0) - static_cast<double>(v < 0.0);
}

// One component's acceleration with damping: the unbalanced force `f` (gravity in it), the
// velocity `v` before the kick, the inverse mass and the mass.
DEMBUF_ALWAYS_INLINE double DampedAcceleration(double f, double v, double inv_m, double m,
                                               const BeadDamping& d) {
  return inv_m * (f - d.local_alpha * std::abs(f) * Sign(v) - d.viscous_rate_per_s * m * v);
}

// Half kicks of bead i with its current forces: v += dt/2 a (and w += dt/2 alpha when it
// rotates), done kHalves times. Two are the last step's closing half kick and this step's
// opening one. Component by component, the operations of the Eigen expressions
// v += half * (f / m + g) and w += half / I * t, in their order. A bead with inv_mass 0 is held
// in place: neither its contacts nor gravity move or turn it. With kClear, the force (and
// torque) is set to zero once read: the force pass that follows the drift then need not clear
// it in a pass of its own.
//
// With kDamp, the beads' own damping acts in every kick, from the velocity before it: the two
// halves of a fused kick are then PFC's leapfrog step v(t + dt/2) = v(t - dt/2) + dt (F + F_d)/m.
template <bool kRotate, int kHalves, bool kClear, bool kDamp = false>
DEMBUF_ALWAYS_INLINE Velocity KickBead(const Kinematics& k, long i, double half, const Vec3& g,
                                       const BeadDamping& damping = {}) {
  const double inv_m = k.inv_mass[i];
  const bool held = inv_m == 0.0;
  double* f = k.force + 3 * i;
  double* v = k.velocity + 3 * i;
  double dvx, dvy, dvz;
  if constexpr (kDamp) {
    const double m = held ? 0.0 : k.mass[i];
    dvx = half * DampedAcceleration(f[0] + m * g.x(), v[0], inv_m, m, damping);
    dvy = half * DampedAcceleration(f[1] + m * g.y(), v[1], inv_m, m, damping);
    dvz = half * DampedAcceleration(f[2] + m * g.z(), v[2], inv_m, m, damping);
  } else {
    dvx = half * (inv_m * f[0] + (held ? 0.0 : g.x()));
    dvy = half * (inv_m * f[1] + (held ? 0.0 : g.y()));
    dvz = half * (inv_m * f[2] + (held ? 0.0 : g.z()));
  }
  if constexpr (kClear) f[0] = f[1] = f[2] = 0.0;
  Velocity u{v[0], v[1], v[2]};
  for (int h = 0; h < kHalves; ++h) {
    u.x += dvx;
    u.y += dvy;
    u.z += dvz;
  }
  v[0] = u.x;
  v[1] = u.y;
  v[2] = u.z;
  if constexpr (kRotate) {
    const double inv_inertia = ParticleState::InverseSphereInertia(k.mass[i], k.radius[i]);
    const double s = held ? 0.0 : half * inv_inertia;
    double* t = k.torque + 3 * i;
    double* w = k.angular_velocity + 3 * i;
    double dwx, dwy, dwz;
    if constexpr (kDamp) {
      const double inertia = held ? 0.0 : 1.0 / inv_inertia;
      const double h = held ? 0.0 : half;
      dwx = h * DampedAcceleration(t[0], w[0], inv_inertia, inertia, damping);
      dwy = h * DampedAcceleration(t[1], w[1], inv_inertia, inertia, damping);
      dwz = h * DampedAcceleration(t[2], w[2], inv_inertia, inertia, damping);
    } else {
      dwx = s * t[0];
      dwy = s * t[1];
      dwz = s * t[2];
    }
    if constexpr (kClear) t[0] = t[1] = t[2] = 0.0;
    for (int h = 0; h < kHalves; ++h) {
      w[0] += dwx;
      w[1] += dwy;
      w[2] += dwz;
    }
  }
  return u;
}

// One half kick of beads [first, last): the closing one left pending when something reads
// the beads between steps (CompleteKick), not one of the step's hot loops.
template <bool kRotate, bool kDamp>
void Kick(const Kinematics& k, long first, long last, double half, const Vec3& g,
          const BeadDamping& damping) {
#pragma omp simd
  for (long i = first; i < last; ++i) KickBead<kRotate, 1, false, kDamp>(k, i, half, g, damping);
}

// What the drift of a block of beads saw: the largest squared displacement since the last list
// build, and how many beads may have gone wrong: non-finite (their components' sum is not
// finite) or outside the container.
struct DriftWatch {
  double max_disp2 = 0.0;
  long suspects = 0;
};

// Everything a block's kick and drift need besides the bead arrays.
struct DriftInputs {
  double half, dt;
  Vec3 g;
  const float* reference;  // positions at the last list build
  Container box;
  BeadDamping damping;
};

// The opening half kick (after the last step's closing one: kHalves = 2) and the drift of beads
// [first, last), in one pass over them (a pass for each read the velocities and radii twice:
// the whole step 9% slower), their forces and torques cleared for the next force pass. `k`
// and `in` are copies: through references, every store to the arrays might change them for
// the compiler, which would load them again after it and not vectorize the loop.
template <bool kRotate, int kHalves, bool kDamp = false>
DEMBUF_ALWAYS_INLINE DriftWatch KickAndDrift(const Kinematics k, long first, long last,
                                             const DriftInputs in) {
  const double dt = in.dt;
  const float* reference = in.reference;
  double disp2 = 0.0;
  long count = 0;
#pragma omp simd reduction(max : disp2) reduction(+ : count)
  for (long i = first; i < last; ++i) {
    const Velocity v = KickBead<kRotate, kHalves, true, kDamp>(k, i, in.half, in.g, in.damping);
    double* x = k.position + 3 * i;
    x[0] += dt * v.x;
    x[1] += dt * v.y;
    x[2] += dt * v.z;
    const double dx = x[0] - reference[3 * i], dy = x[1] - reference[3 * i + 1],
                 dz = x[2] - reference[3 * i + 2];
    const double d2 = dx * dx + dy * dy + dz * dz;
    disp2 = d2 > disp2 ? d2 : disp2;
    const double sum = ((x[0] + x[1]) + (x[2] + v.x)) + (v.y + v.z);
    count += !std::isfinite(sum) || in.box.Escaped(x[0], x[1], x[2], k.radius[i]);
  }
  return {disp2, count};
}

DEMBUF_VECTOR_COPIES(DriftWatch, KickAndDriftRotating,
                     (const Kinematics k, long first, long last, const DriftInputs& in),
                     (KickAndDrift<true, 1>(k, first, last, in)))
DEMBUF_VECTOR_COPIES(DriftWatch, KickTwiceAndDriftRotating,
                     (const Kinematics k, long first, long last, const DriftInputs& in),
                     (KickAndDrift<true, 2>(k, first, last, in)))
DEMBUF_VECTOR_COPIES(DriftWatch, KickAndDriftNotRotating,
                     (const Kinematics k, long first, long last, const DriftInputs& in),
                     (KickAndDrift<false, 1>(k, first, last, in)))
DEMBUF_VECTOR_COPIES(DriftWatch, KickTwiceAndDriftNotRotating,
                     (const Kinematics k, long first, long last, const DriftInputs& in),
                     (KickAndDrift<false, 2>(k, first, last, in)))

// With damping (a scene that asks for it; not a hot path of the paper's model): one copy
// each, rotating or not, the closing half kick fused or not.
DEMBUF_VECTOR_COPIES(DriftWatch, DampedKickAndDriftRotating,
                     (const Kinematics k, long first, long last, const DriftInputs& in),
                     (KickAndDrift<true, 1, true>(k, first, last, in)))
DEMBUF_VECTOR_COPIES(DriftWatch, DampedKickTwiceAndDriftRotating,
                     (const Kinematics k, long first, long last, const DriftInputs& in),
                     (KickAndDrift<true, 2, true>(k, first, last, in)))
DEMBUF_VECTOR_COPIES(DriftWatch, DampedKickAndDriftNotRotating,
                     (const Kinematics k, long first, long last, const DriftInputs& in),
                     (KickAndDrift<false, 1, true>(k, first, last, in)))
DEMBUF_VECTOR_COPIES(DriftWatch, DampedKickTwiceAndDriftNotRotating,
                     (const Kinematics k, long first, long last, const DriftInputs& in),
                     (KickAndDrift<false, 2, true>(k, first, last, in)))

Vec3 Gravity(const WorldParams& params) {
  return Vec3(0.0, 0.0, -params.gravity_m_s2);
}

}  // namespace

DriftReport KickAndDriftBeads(const WorldParams& params, bool closing, ParticleState& b,
                              Simulation::Impl& s) {
  const double dt = params.dt_s;
  const DriftInputs in{0.5 * dt,         dt,
                       Gravity(params),  s.lists.reference_position.data(),
                       params.container, params.bead_damping};
  const long n = static_cast<long>(b.size());
  const Kinematics k = BeadKinematics(b);
  const bool rotate = s.Rotating();
  // The copies for this CPU (vector_copies.h), chosen at the first call.
  static const auto once_rotating = DEMBUF_PICK_COPY(KickAndDriftRotating);
  static const auto twice_rotating = DEMBUF_PICK_COPY(KickTwiceAndDriftRotating);
  static const auto once_still = DEMBUF_PICK_COPY(KickAndDriftNotRotating);
  static const auto twice_still = DEMBUF_PICK_COPY(KickTwiceAndDriftNotRotating);
  static const auto damped_once_rotating = DEMBUF_PICK_COPY(DampedKickAndDriftRotating);
  static const auto damped_twice_rotating = DEMBUF_PICK_COPY(DampedKickTwiceAndDriftRotating);
  static const auto damped_once_still = DEMBUF_PICK_COPY(DampedKickAndDriftNotRotating);
  static const auto damped_twice_still = DEMBUF_PICK_COPY(DampedKickTwiceAndDriftNotRotating);
  const auto pass = params.bead_damping.Any()
                        ? (rotate ? (closing ? damped_twice_rotating : damped_once_rotating)
                                  : (closing ? damped_twice_still : damped_once_still))
                        : (rotate ? (closing ? twice_rotating : once_rotating)
                                  : (closing ? twice_still : once_still));
  DriftWatch watch;
#pragma omp parallel num_threads(s.threads) if (s.parallel)
  {
    const int team = omp_get_num_threads(), thread = omp_get_thread_num();
    const auto [first, last] = s.blocks.shares.Part(n, thread, team);
    const DriftWatch mine = pass(k, first, last, in);
#pragma omp critical
    {
      watch.max_disp2 = std::max(watch.max_disp2, mine.max_disp2);
      watch.suspects += mine.suspects;
    }
  }
  DriftReport report;
  report.max_displacement = std::sqrt(watch.max_disp2);
  if (watch.suspects > 0) {  // rare: find the beads for the message
    for (long i = 0; i < n; ++i) {
      const Vec3& x = b.position[i];
      if (!x.allFinite() || !b.velocity[i].allFinite()) report.nonfinite_bead = i;
      if (in.box.Escaped(x.x(), x.y(), x.z(), b.radius[i])) report.escaped_bead = i;
    }
  }
  return report;
}

void HalfKickBeads(const WorldParams& params, ParticleState& b, const Simulation::Impl& s) {
  const double half = 0.5 * params.dt_s;
  const Vec3 g = Gravity(params);
  const long n = static_cast<long>(b.size());
  const Kinematics k = BeadKinematics(b);
  const bool rotate = s.Rotating();
#pragma omp parallel num_threads(s.threads) if (s.parallel)
  {
    const int team = omp_get_num_threads(), thread = omp_get_thread_num();
    const auto [first, last] = s.blocks.shares.Part(n, thread, team);
    const BeadDamping& damping = params.bead_damping;
    if (damping.Any()) {
      if (rotate)
        Kick<true, true>(k, first, last, half, g, damping);
      else
        Kick<false, true>(k, first, last, half, g, damping);
    } else if (rotate) {
      Kick<true, false>(k, first, last, half, g, damping);
    } else {
      Kick<false, false>(k, first, last, half, g, damping);
    }
  }
}

void HalfKickProjectile(const WorldParams& params, bool rotate, RigidSphere& p) {
  const double half = 0.5 * params.dt_s;
  p.velocity += half * (p.force / p.mass + Gravity(params));
  if (rotate) p.angular_velocity += half * p.torque / p.Inertia();
}

}  // namespace dembuf::dem::detail
