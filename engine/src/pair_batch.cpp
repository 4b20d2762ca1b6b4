#include "pair_batch.h"

#include <cmath>

namespace dembuf::detail {

void PairBatch::Grow(std::size_t n) {
  bead.resize(n);
  partner.resize(n);
  entry.resize(n);
  apart.resize(n);
  overlap.resize(n);
  for (int d = 0; d < 3; ++d) {
    force[d].resize(n);
    torque_bead[d].resize(n);
    torque_partner[d].resize(n);
    shear[d].resize(n);
  }
}

namespace {

// One contact per loop iteration, written component by component so that the loop
// vectorizes; each line mirrors the Eigen expression of MakeGeometry, HertzMindlinForce or
// Resolve that it replaces (same operation order, so the same bits).
template <bool kFriction>
inline __attribute__((always_inline)) void ResolveBody(const PairBatchInputs& in,
                                                       PairBatch& batch) {
  const std::uint32_t* bead = batch.bead.data();
  const std::uint32_t* partner = batch.partner.data();
  const std::uint32_t* entry = batch.entry.data();
  double* overlap_out = batch.overlap.data();
  double *fx = batch.force[0].data(), *fy = batch.force[1].data(), *fz = batch.force[2].data();
  double *tix = batch.torque_bead[0].data(), *tiy = batch.torque_bead[1].data(),
         *tiz = batch.torque_bead[2].data();
  double *tjx = batch.torque_partner[0].data(), *tjy = batch.torque_partner[1].data(),
         *tjz = batch.torque_partner[2].data();
  double *hx_out = batch.shear[0].data(), *hy_out = batch.shear[1].data(),
         *hz_out = batch.shear[2].data();
  const double* x = in.position;
  const double* v = in.velocity;
  const double* w = in.angular_velocity;
  const double* radius = in.radius;
  const double* sqrt_r_star = in.sqrt_r_star;
  const double* shear = in.shear;
  const double kn_per_sqrt_r = in.params.kn_per_sqrt_r;
  const double ks_per_sqrt_r = in.params.ks_per_sqrt_r;
  const double damping = in.params.damping_A_s;
  const double mu = in.params.friction;
  const double dt = in.dt;
  const std::size_t n = batch.size;

#pragma omp simd
  for (std::size_t c = 0; c < n; ++c) {
    const std::size_t i = bead[c], j = partner[c], k = entry[c];
    // Geometry: normal from j to i, overlap, lever arms.
    const double dx = x[3 * i] - x[3 * j], dy = x[3 * i + 1] - x[3 * j + 1],
                 dz = x[3 * i + 2] - x[3 * j + 2];
    const double ri = radius[i], rj = radius[j];
    const double dist = std::sqrt(dx * dx + dy * dy + dz * dz);
    const double overlap = (ri + rj) - dist;
    const double inv_dist = 1.0 / dist;
    const double nx = dx * inv_dist, ny = dy * inv_dist, nz = dz * inv_dist;
    const double ai = ri - 0.5 * overlap, aj = rj - 0.5 * overlap;
    // Relative velocity, approach rate and (with friction) slip at the contact point.
    const double vx = v[3 * i] - v[3 * j], vy = v[3 * i + 1] - v[3 * j + 1],
                 vz = v[3 * i + 2] - v[3 * j + 2];
    const double approach = -(vx * nx + vy * ny + vz * nz);
    // Hertz normal force with nonlinear damping, clamped at 0.
    const double sqrt_x = std::sqrt(overlap);
    const double f = kn_per_sqrt_r * sqrt_r_star[k] * sqrt_x * (overlap + damping * approach);
    const double fn = f > 0.0 ? f : 0.0;
    overlap_out[c] = overlap;
    if constexpr (!kFriction) {
      fx[c] = fn * nx;
      fy[c] = fn * ny;
      fz[c] = fn * nz;
    } else {
      const double wx = ai * w[3 * i] + aj * w[3 * j], wy = ai * w[3 * i + 1] + aj * w[3 * j + 1],
                   wz = ai * w[3 * i + 2] + aj * w[3 * j + 2];
      const double sx = (vx + approach * nx) - (wy * nz - wz * ny);
      const double sy = (vy + approach * ny) - (wz * nx - wx * nz);
      const double sz = (vz + approach * nz) - (wx * ny - wy * nx);
      // The history, turned into the tangent plane with its length kept.
      double hx = shear[3 * k], hy = shear[3 * k + 1], hz = shear[3 * k + 2];
      const double old_norm2 = hx * hx + hy * hy + hz * hz;
      const double along = hx * nx + hy * ny + hz * nz;
      const double px = hx - along * nx, py = hy - along * ny, pz = hz - along * nz;
      const double new_norm2 = px * px + py * py + pz * pz;
      // Computed in every lane and used where the scalar code would (selects, not branches).
      const double rescale = std::sqrt(old_norm2 / new_norm2);
      const bool turn = old_norm2 > 0.0;
      const bool scale = new_norm2 > 0.0;
      hx = turn ? (scale ? px * rescale : px) : hx;
      hy = turn ? (scale ? py * rescale : py) : hy;
      hz = turn ? (scale ? pz * rescale : pz) : hz;
      hx = hx + sx * dt;
      hy = hy + sy * dt;
      hz = hz + sz * dt;
      // Mindlin spring, capped at mu Fn; while sliding the spring shortens to the cap.
      const double ks_x = ks_per_sqrt_r * sqrt_r_star[k] * sqrt_x;
      double tx = -ks_x * hx, ty = -ks_x * hy, tz = -ks_x * hz;
      const double cap = mu * fn;
      const double ft2 = tx * tx + ty * ty + tz * tz;
      const bool slide = ft2 > cap * cap;
      const double shorten = cap / std::sqrt(ft2);
      tx = slide ? tx * shorten : tx;
      ty = slide ? ty * shorten : ty;
      tz = slide ? tz * shorten : tz;
      const bool spring = ks_x > 0.0;
      const double ux = -tx / ks_x, uy = -ty / ks_x, uz = -tz / ks_x;
      hx_out[c] = slide ? (spring ? ux : 0.0) : hx;
      hy_out[c] = slide ? (spring ? uy : 0.0) : hy;
      hz_out[c] = slide ? (spring ? uz : 0.0) : hz;
      fx[c] = fn * nx + tx;
      fy[c] = fn * ny + ty;
      fz[c] = fn * nz + tz;
      // Both torques are -a (n x Ft).
      const double mx = ny * tz - nz * ty, my = nz * tx - nx * tz, mz = nx * ty - ny * tx;
      tix[c] = -ai * mx;
      tiy[c] = -ai * my;
      tiz[c] = -ai * mz;
      tjx[c] = -aj * mx;
      tjy[c] = -aj * my;
      tjz[c] = -aj * mz;
    }
  }
}

// One copy per instruction set; the dynamic loader picks the widest the CPU supports.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define DEMBUF_VECTOR_CLONES \
  __attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default")))
#else
#define DEMBUF_VECTOR_CLONES
#endif

DEMBUF_VECTOR_CLONES void ResolveWithFriction(const PairBatchInputs& in, PairBatch& batch) {
  ResolveBody<true>(in, batch);
}

DEMBUF_VECTOR_CLONES void ResolveWithoutFriction(const PairBatchInputs& in, PairBatch& batch) {
  ResolveBody<false>(in, batch);
}

}  // namespace

void ResolvePairBatch(bool friction, const PairBatchInputs& in, PairBatch& batch) {
  if (friction)
    ResolveWithFriction(in, batch);
  else
    ResolveWithoutFriction(in, batch);
}

}  // namespace dembuf::detail
