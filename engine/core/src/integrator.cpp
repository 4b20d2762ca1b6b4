#include "integrator.h"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <type_traits>
#include <utility>

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

// Half kicks of bead i with its current forces: v += dt/2 a (and w += dt/2 alpha when it
// rotates, E::kRotate), done kHalves times. Two are the last step's closing half kick and this
// step's opening one. Component by component, the operations of the Eigen expressions
// v += half * (f / m + g) and w += half / I * t, in their order. A bead with inv_mass 0 is held
// in place: neither its contacts nor gravity move or turn it. With kClear, the force (and
// torque) is set to zero once read: the force pass that follows the drift then need not clear
// it in a pass of its own.
//
// A motion part that sets the acceleration (AccelerationPart, e.g. the beads' own damping)
// gives it from the unbalanced force (gravity in it) and the velocity before the kick.
template <class E, int kHalves, bool kClear>
DEMBUF_ALWAYS_INLINE Velocity KickBead(const Kinematics& k, long i, double half, const Vec3& g,
                                       const AccelerationParams& shaping) {
  using Shaping = AccelerationPart<E>;
  constexpr bool kShaped = !std::is_void_v<Shaping>;
  const double inv_m = k.inv_mass[i];
  const bool held = inv_m == 0.0;
  double* f = k.force + 3 * i;
  double* v = k.velocity + 3 * i;
  double dvx, dvy, dvz;
  if constexpr (kShaped) {
    const double m = held ? 0.0 : k.mass[i];
    dvx = half * Shaping::Acceleration(f[0] + m * g.x(), v[0], inv_m, m, shaping);
    dvy = half * Shaping::Acceleration(f[1] + m * g.y(), v[1], inv_m, m, shaping);
    dvz = half * Shaping::Acceleration(f[2] + m * g.z(), v[2], inv_m, m, shaping);
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
  if constexpr (E::kRotate) {
    const double inv_inertia = ParticleState::InverseSphereInertia(k.mass[i], k.radius[i]);
    const double s = held ? 0.0 : half * inv_inertia;
    double* t = k.torque + 3 * i;
    double* w = k.angular_velocity + 3 * i;
    double dwx, dwy, dwz;
    if constexpr (kShaped) {
      const double inertia = held ? 0.0 : 1.0 / inv_inertia;
      const double h = held ? 0.0 : half;
      dwx = h * Shaping::Acceleration(t[0], w[0], inv_inertia, inertia, shaping);
      dwy = h * Shaping::Acceleration(t[1], w[1], inv_inertia, inertia, shaping);
      dwz = h * Shaping::Acceleration(t[2], w[2], inv_inertia, inertia, shaping);
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
template <class E>
void Kick(const Kinematics& k, long first, long last, double half, const Vec3& g,
          const AccelerationParams& shaping) {
#pragma omp simd
  for (long i = first; i < last; ++i) KickBead<E, 1, false>(k, i, half, g, shaping);
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
  AccelerationParams shaping;  // the parameters of a part that sets the acceleration
};

// The opening half kick (after the last step's closing one: kHalves = 2) and the drift of beads
// [first, last), in one pass over them (a pass for each read the velocities and radii twice:
// the whole step 9% slower), their forces and torques cleared for the next force pass. `k`
// and `in` are copies: through references, every store to the arrays might change them for
// the compiler, which would load them again after it and not vectorize the loop.
template <class E, int kHalves>
DEMBUF_ALWAYS_INLINE DriftWatch KickAndDrift(const Kinematics k, long first, long last,
                                             const DriftInputs in) {
  const double dt = in.dt;
  const float* reference = in.reference;
  double disp2 = 0.0;
  long count = 0;
#pragma omp simd reduction(max : disp2) reduction(+ : count)
  for (long i = first; i < last; ++i) {
    const Velocity v = KickBead<E, kHalves, true>(k, i, in.half, in.g, in.shaping);
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

// For each instance of the motion parts (parts.h), the closing half kick fused or not, each
// compiled for several instruction sets.
DEMBUF_VECTOR_COPIES_OF(DriftWatch, KickOnceAndDrift,
                        (const Kinematics k, long first, long last, const DriftInputs& in),
                        (KickAndDrift<E, 1>(k, first, last, in)))
DEMBUF_VECTOR_COPIES_OF(DriftWatch, KickTwiceAndDrift,
                        (const Kinematics k, long first, long last, const DriftInputs& in),
                        (KickAndDrift<E, 2>(k, first, last, in)))

Vec3 Gravity(const WorldParams& params) {
  return Vec3(0.0, 0.0, -params.gravity_m_s2);
}

}  // namespace

DriftReport KickAndDriftBeads(const WorldParams& params, bool closing, ParticleState& b,
                              Simulation::Impl& s) {
  const double dt = params.dt_s;
  const DriftInputs in{0.5 * dt,         dt,
                       Gravity(params),  s.lists.reference_position.data(),
                       params.container, AccelerationParamsOf(params)};
  const long n = static_cast<long>(b.size());
  const Kinematics k = BeadKinematics(b);
  // The instances for this CPU (vector_copies.h), chosen at the first call.
  static const auto once = InstanceTable<Stage::kMotion>(
      []<class E>(E) { return DEMBUF_PICK_COPY_OF(KickOnceAndDrift, E); });
  static const auto twice = InstanceTable<Stage::kMotion>(
      []<class E>(E) { return DEMBUF_PICK_COPY_OF(KickTwiceAndDrift, E); });
  const std::size_t instance = detail::InstanceIndex<Stage::kMotion>(s.active_parts);
  const auto pass = (closing ? twice : once)[instance];
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
  const AccelerationParams shaping = AccelerationParamsOf(params);
#pragma omp parallel num_threads(s.threads) if (s.parallel)
  {
    const int team = omp_get_num_threads(), thread = omp_get_thread_num();
    const std::pair<long, long> share = s.blocks.shares.Part(n, thread, team);
    WithEffects<Stage::kMotion>(s.active_parts, [&]<class E>(E) {
      Kick<E>(k, share.first, share.second, half, g, shaping);
    });
  }
}

void HalfKickProjectile(const WorldParams& params, bool rotate, RigidSphere& p) {
  const double half = 0.5 * params.dt_s;
  p.velocity += half * (p.force / p.mass + Gravity(params));
  if (rotate) p.angular_velocity += half * p.torque / p.Inertia();
}

}  // namespace dembuf::dem::detail
