#include "integrator.h"

#include <omp.h>

#include <algorithm>
#include <cmath>

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

// Half kicks of beads [first, last) with their current forces: v += dt/2 a (and w += dt/2 alpha
// when they rotate), done kHalves times. Two are the last step's closing half kick and this
// step's opening one, in one pass over the beads. Component by component, the operations of
// the Eigen expressions v += half * (f / m + g) and w += half / I * t, in their order.
// A bead with inv_mass 0 is held in place: neither its contacts nor gravity move or turn it.
// With kClear, the forces (and torques) are set to zero once read: the force pass that follows
// the drift then need not clear them in a pass of its own.
template <bool kRotate, int kHalves = 1, bool kClear = false>
void Kick(const Kinematics& k, long first, long last, double half, const Vec3& g) {
  const double gx = g.x(), gy = g.y(), gz = g.z();
#pragma omp simd
  for (long i = first; i < last; ++i) {
    const double inv_m = k.inv_mass[i];
    const bool held = inv_m == 0.0;
    const double dvx = half * (inv_m * k.force[3 * i] + (held ? 0.0 : gx));
    const double dvy = half * (inv_m * k.force[3 * i + 1] + (held ? 0.0 : gy));
    const double dvz = half * (inv_m * k.force[3 * i + 2] + (held ? 0.0 : gz));
    if constexpr (kClear) k.force[3 * i] = k.force[3 * i + 1] = k.force[3 * i + 2] = 0.0;
    for (int h = 0; h < kHalves; ++h) {
      k.velocity[3 * i] += dvx;
      k.velocity[3 * i + 1] += dvy;
      k.velocity[3 * i + 2] += dvz;
    }
    if constexpr (kRotate) {
      const double inv_inertia = ParticleState::InverseSphereInertia(k.mass[i], k.radius[i]);
      const double s = held ? 0.0 : half * inv_inertia;
      const double dwx = s * k.torque[3 * i], dwy = s * k.torque[3 * i + 1],
                   dwz = s * k.torque[3 * i + 2];
      if constexpr (kClear) k.torque[3 * i] = k.torque[3 * i + 1] = k.torque[3 * i + 2] = 0.0;
      for (int h = 0; h < kHalves; ++h) {
        k.angular_velocity[3 * i] += dwx;
        k.angular_velocity[3 * i + 1] += dwy;
        k.angular_velocity[3 * i + 2] += dwz;
      }
    }
  }
}

// The opening half kick (after the last step's closing one when `closing`) and the drift of
// beads [first, last), their forces and torques cleared for the next force pass; with the
// largest squared displacement since the last list build and a count of beads that may have
// gone wrong: non-finite (their components' sum is not finite) or outside the container.
template <bool kRotate>
void KickAndDrift(const Kinematics& k, long first, long last, bool closing, double half, double dt,
                  const Vec3& g, const float* reference, const Container& box, double& max_disp2,
                  long& suspects) {
  if (closing)
    Kick<kRotate, 2, true>(k, first, last, half, g);
  else
    Kick<kRotate, 1, true>(k, first, last, half, g);
  double disp2 = 0.0;
  long count = 0;
#pragma omp simd reduction(max : disp2) reduction(+ : count)
  for (long i = first; i < last; ++i) {
    double* x = k.position + 3 * i;
    const double* v = k.velocity + 3 * i;
    x[0] += dt * v[0];
    x[1] += dt * v[1];
    x[2] += dt * v[2];
    const double dx = x[0] - reference[3 * i], dy = x[1] - reference[3 * i + 1],
                 dz = x[2] - reference[3 * i + 2];
    const double d2 = dx * dx + dy * dy + dz * dz;
    disp2 = d2 > disp2 ? d2 : disp2;
    const double sum = ((x[0] + x[1]) + (x[2] + v[0])) + (v[1] + v[2]);
    const bool suspect = !std::isfinite(sum) || box.Escaped(x[0], x[1], x[2], k.radius[i]);
    count += suspect;
  }
  max_disp2 = std::max(max_disp2, disp2);
  suspects += count;
}

Vec3 Gravity(const WorldParams& params) {
  return Vec3(0.0, 0.0, -params.gravity_m_s2);
}

}  // namespace

DriftReport KickAndDriftBeads(const WorldParams& params, bool closing, ParticleState& b,
                              Simulation::Impl& s) {
  const double dt = params.dt_s;
  const double half = 0.5 * dt;
  const Vec3 g = Gravity(params);
  const Container box = params.container;
  const long n = static_cast<long>(b.size());
  const Kinematics k = BeadKinematics(b);
  const float* reference = s.lists.reference_position.data();
  const bool rotate = s.Rotating();
  double max_disp2 = 0.0;
  long suspects = 0;  // beads that may be non-finite or outside the container
#pragma omp parallel num_threads(s.threads) if (s.parallel)
  {
    double thread_disp2 = 0.0;
    long thread_suspects = 0;
    const int team = omp_get_num_threads(), thread = omp_get_thread_num();
    const auto [first, last] = s.blocks.shares.Part(n, thread, team);
    if (rotate)
      KickAndDrift<true>(k, first, last, closing, half, dt, g, reference, box, thread_disp2,
                         thread_suspects);
    else
      KickAndDrift<false>(k, first, last, closing, half, dt, g, reference, box, thread_disp2,
                          thread_suspects);
#pragma omp critical
    {
      max_disp2 = std::max(max_disp2, thread_disp2);
      suspects += thread_suspects;
    }
  }
  DriftReport report;
  report.max_displacement = std::sqrt(max_disp2);
  if (suspects > 0) {  // rare: find the beads for the message
    for (long i = 0; i < n; ++i) {
      const Vec3& x = b.position[i];
      if (!x.allFinite() || !b.velocity[i].allFinite()) report.nonfinite_bead = i;
      if (box.Escaped(x.x(), x.y(), x.z(), b.radius[i])) report.escaped_bead = i;
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
    if (rotate)
      Kick<true>(k, first, last, half, g);
    else
      Kick<false>(k, first, last, half, g);
  }
}

void HalfKickProjectile(const WorldParams& params, bool rotate, RigidSphere& p) {
  const double half = 0.5 * params.dt_s;
  p.velocity += half * (p.force / p.mass + Gravity(params));
  if (rotate) p.angular_velocity += half * p.torque / p.Inertia();
}

}  // namespace dembuf::dem::detail
