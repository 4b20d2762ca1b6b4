#include "pair_batch.h"

#include <cmath>

#include "vector_copies.h"

namespace dembuf::dem::detail {

namespace {

// Where the law writes one contact's results (arrays of one component each).
struct LawResults {
  double *fx, *fy, *fz;     // force on the bead
  double *tix, *tiy, *tiz;  // torque on the bead
  double *tjx, *tjy, *tjz;  // torque on the partner (not written for a wall)
  double *hx, *hy, *hz;     // the advanced history
  double* normal_force;     // magnitude of the normal force (kept for a wall)
};

// What the bead touches: another bead (which takes a torque too) or a wall (whose normal force
// is summed into the observables).
enum class Partner { kBead, kWall };

// One contact's geometry, as MakeGeometry takes it: unit normal n (towards the bead), overlap,
// relative velocity v (bead minus partner), w_arm = ai w_bead + aj w_partner, lever arms.
struct LaneGeometry {
  double nx, ny, nz, overlap;
  double vx, vy, vz;
  double wx, wy, wz;
  double r_star, ai, aj;
  // Rolling resistance's inputs (RollingPair): w_bead - w_partner, the pair's inertia.
  double rwx, rwy, rwz, inertia;
};

// Contact c (one lane of a vectorized loop): the slip from MakeGeometry's expression, the law
// itself (ApplyContactLaw, the one copy of it), then forces and torques as Resolve makes them,
// component by component in the same operation order, so the same bits. Its history before
// this step is history[3 k .. 3 k + 2] (indexed here, not through a pointer to it: that form
// gathers).
template <bool kFriction, bool kRolling, Partner kPartner>
inline __attribute__((always_inline)) void ResolveLane(const LaneGeometry& g, const PairParams& p,
                                                       double mu_r, double dt,
                                                       const double* history, std::size_t k,
                                                       const LawResults& out, std::size_t c) {
  const double nx = g.nx, ny = g.ny, nz = g.nz;
  ContactLawInput in;
  in.nx = nx;
  in.ny = ny;
  in.nz = nz;
  in.overlap = g.overlap;
  in.approach_rate = -(g.vx * nx + g.vy * ny + g.vz * nz);
  in.r_star = g.r_star;
  if constexpr (kFriction) {
    const double approach = in.approach_rate;
    in.sx = (g.vx + approach * nx) - (g.wy * nz - g.wz * ny);
    in.sy = (g.vy + approach * ny) - (g.wz * nx - g.wx * nz);
    in.sz = (g.vz + approach * nz) - (g.wx * ny - g.wy * nx);
    in.hx = history[3 * k];
    in.hy = history[3 * k + 1];
    in.hz = history[3 * k + 2];
  } else {
    in.sx = in.sy = in.sz = in.hx = in.hy = in.hz = 0.0;
  }
  const ContactLawOutput law = ApplyContactLaw<kFriction>(in, p, dt);
  const double fn = law.normal;
  if constexpr (kPartner == Partner::kWall) out.normal_force[c] = fn;
  double tix = 0.0, tiy = 0.0, tiz = 0.0, tjx = 0.0, tjy = 0.0, tjz = 0.0;
  if constexpr (!kFriction) {
    out.fx[c] = fn * nx;
    out.fy[c] = fn * ny;
    out.fz[c] = fn * nz;
  } else {
    const double tx = law.tx, ty = law.ty, tz = law.tz;
    out.hx[c] = law.hx;
    out.hy[c] = law.hy;
    out.hz[c] = law.hz;
    out.fx[c] = fn * nx + tx;
    out.fy[c] = fn * ny + ty;
    out.fz[c] = fn * nz + tz;
    // Both torques are -a (n x Ft).
    const double mx = ny * tz - nz * ty, my = nz * tx - nx * tz, mz = nx * ty - ny * tx;
    tix = -g.ai * mx;
    tiy = -g.ai * my;
    tiz = -g.ai * mz;
    tjx = -g.aj * mx;
    tjy = -g.aj * my;
    tjz = -g.aj * mz;
  }
  if constexpr (kRolling) {
    const RollingOutput rolling = ApplyRollingResistance(
        {nx, ny, nz, g.rwx, g.rwy, g.rwz, fn, g.r_star, g.inertia}, mu_r, dt);
    tix = tix + rolling.tx;
    tiy = tiy + rolling.ty;
    tiz = tiz + rolling.tz;
    tjx = tjx - rolling.tx;
    tjy = tjy - rolling.ty;
    tjz = tjz - rolling.tz;
  }
  if constexpr (kFriction || kRolling) {
    out.tix[c] = tix;
    out.tiy[c] = tiy;
    out.tiz[c] = tiz;
    if constexpr (kPartner == Partner::kBead) {
      out.tjx[c] = tjx;
      out.tjy[c] = tjy;
      out.tjz[c] = tjz;
    }
  }
}

// Bead pairs, one contact per loop iteration (the loop vectorizes: gathers of both beads'
// state, vector square roots and divisions, masks for the law's branches).
template <bool kFriction, bool kRolling>
inline __attribute__((always_inline)) void ResolveBody(const PairBatchInputs& in,
                                                       PairBatch& batch) {
  const std::uint32_t* bead = batch.bead.data();
  const std::uint32_t* partner = batch.partner.data();
  const std::uint32_t* entry = batch.entry.data();
  double* overlap_out = batch.overlap.data();
  const LawResults out{batch.force[0].data(),
                       batch.force[1].data(),
                       batch.force[2].data(),
                       batch.torque_bead[0].data(),
                       batch.torque_bead[1].data(),
                       batch.torque_bead[2].data(),
                       batch.torque_partner[0].data(),
                       batch.torque_partner[1].data(),
                       batch.torque_partner[2].data(),
                       batch.shear[0].data(),
                       batch.shear[1].data(),
                       batch.shear[2].data(),
                       nullptr};
  const double* x = in.position;
  const double* v = in.velocity;
  const double* w = in.angular_velocity;
  const double* radius = in.radius;
  const double* mass = in.mass;
  const double* shear = in.shear;
  // Copies: the stores to the result arrays could otherwise alias them.
  const PairParams params = in.params;
  const double mu_r = in.rolling_friction;
  const double dt = in.dt;
  const std::size_t n = batch.size;

#pragma omp simd
  for (std::size_t c = 0; c < n; ++c) {
    const std::size_t i = bead[c], j = partner[c];
    // Normal from j to i, overlap, lever arms.
    const double dx = x[3 * i] - x[3 * j], dy = x[3 * i + 1] - x[3 * j + 1],
                 dz = x[3 * i + 2] - x[3 * j + 2];
    const double ri = radius[i], rj = radius[j];
    const double dist = std::sqrt(dx * dx + dy * dy + dz * dz);
    LaneGeometry g;
    g.overlap = (ri + rj) - dist;
    const double inv_dist = 1.0 / dist;
    g.nx = dx * inv_dist;
    g.ny = dy * inv_dist;
    g.nz = dz * inv_dist;
    g.ai = ri - 0.5 * g.overlap;
    g.aj = rj - 0.5 * g.overlap;
    g.vx = v[3 * i] - v[3 * j];
    g.vy = v[3 * i + 1] - v[3 * j + 1];
    g.vz = v[3 * i + 2] - v[3 * j + 2];
    if constexpr (kFriction) {
      g.wx = g.ai * w[3 * i] + g.aj * w[3 * j];
      g.wy = g.ai * w[3 * i + 1] + g.aj * w[3 * j + 1];
      g.wz = g.ai * w[3 * i + 2] + g.aj * w[3 * j + 2];
    } else {
      g.wx = g.wy = g.wz = 0.0;
    }
    g.r_star = EffectiveRadius(ri, rj);
    if constexpr (kRolling) {
      g.rwx = w[3 * i] - w[3 * j];
      g.rwy = w[3 * i + 1] - w[3 * j + 1];
      g.rwz = w[3 * i + 2] - w[3 * j + 2];
      g.inertia = 1.0 / (ParticleState::InverseSphereInertia(mass[i], ri) +
                         ParticleState::InverseSphereInertia(mass[j], rj));
    }
    overlap_out[c] = g.overlap;
    ResolveLane<kFriction, kRolling, Partner::kBead>(g, params, mu_r, dt, shear, entry[c], out, c);
  }
}

// Beads against the plate (kOnPlate) or the side wall, one contact per loop iteration, as
// the projectile's contacts with them are resolved: the wall does not move and takes no torque (aj
// = 0).
template <bool kFriction, bool kRolling, bool kOnPlate>
inline __attribute__((always_inline)) void ResolveWallBody(const WallBatchInputs& in,
                                                           WallBatch& batch) {
  const std::uint32_t* bead = batch.bead.data();
  const std::uint32_t* slot = batch.slot.data();
  double* overlap_out = batch.overlap.data();
  const LawResults out{batch.force[0].data(),
                       batch.force[1].data(),
                       batch.force[2].data(),
                       batch.torque[0].data(),
                       batch.torque[1].data(),
                       batch.torque[2].data(),
                       nullptr,
                       nullptr,
                       nullptr,
                       batch.shear[0].data(),
                       batch.shear[1].data(),
                       batch.shear[2].data(),
                       batch.normal_force.data()};
  const double* x = in.position;
  const double* v = in.velocity;
  const double* w = in.angular_velocity;
  const double* radius = in.radius;
  const double* mass = in.mass;
  const double* shear = in.shear;
  // Copies: the stores to the result arrays could otherwise alias them.
  const PairParams params = in.params;
  const double mu_r = in.rolling_friction;
  const double dt = in.dt;
  const Container box = in.box;
  const std::size_t n = batch.size;

#pragma omp simd
  for (std::size_t c = 0; c < n; ++c) {
    const std::size_t i = bead[c];
    const double r = radius[i];
    LaneGeometry g;
    if constexpr (kOnPlate) {
      g.overlap = Container::PlateOverlap(x[3 * i + 2], r);
      g.nx = 0.0;
      g.ny = 0.0;
      g.nz = 1.0;
    } else {
      // Normal from the wall's face towards the axis, or from its rim (SideWallContact).
      const double px = x[3 * i], py = x[3 * i + 1], pz = x[3 * i + 2];
      const double rho = std::sqrt(px * px + py * py);
      box.SideWallGeometry(px, py, pz, rho, r, g.overlap, g.nx, g.ny, g.nz);
    }
    g.ai = r - 0.5 * g.overlap;
    g.aj = 0.0;
    g.vx = v[3 * i];
    g.vy = v[3 * i + 1];
    g.vz = v[3 * i + 2];
    g.wx = g.ai * w[3 * i];
    g.wy = g.ai * w[3 * i + 1];
    g.wz = g.ai * w[3 * i + 2];
    g.r_star = r;
    if constexpr (kRolling) {
      g.rwx = w[3 * i];
      g.rwy = w[3 * i + 1];
      g.rwz = w[3 * i + 2];
      g.inertia = 1.0 / ParticleState::InverseSphereInertia(mass[i], r);
    }
    overlap_out[c] = g.overlap;
    ResolveLane<kFriction, kRolling, Partner::kWall>(g, params, mu_r, dt, shear, slot[c], out, c);
  }
}

// One copy of each kind of contact for each set of effects (friction, rolling), each compiled
// for several instruction sets.
#define DEMBUF_PAIR_COPY(name, friction, rolling)                                 \
  DEMBUF_VECTOR_COPIES(void, name, (const PairBatchInputs& in, PairBatch& batch), \
                       (ResolveBody<friction, rolling>(in, batch)))
#define DEMBUF_WALL_COPY(name, friction, rolling, plate)                          \
  DEMBUF_VECTOR_COPIES(void, name, (const WallBatchInputs& in, WallBatch& batch), \
                       (ResolveWallBody<friction, rolling, plate>(in, batch)))
DEMBUF_PAIR_COPY(ResolvePairs, false, false)
DEMBUF_PAIR_COPY(ResolvePairsFriction, true, false)
DEMBUF_PAIR_COPY(ResolvePairsRolling, false, true)
DEMBUF_PAIR_COPY(ResolvePairsFrictionRolling, true, true)
DEMBUF_WALL_COPY(ResolvePlate, false, false, true)
DEMBUF_WALL_COPY(ResolvePlateFriction, true, false, true)
DEMBUF_WALL_COPY(ResolvePlateRolling, false, true, true)
DEMBUF_WALL_COPY(ResolvePlateFrictionRolling, true, true, true)
DEMBUF_WALL_COPY(ResolveSide, false, false, false)
DEMBUF_WALL_COPY(ResolveSideFriction, true, false, false)
DEMBUF_WALL_COPY(ResolveSideRolling, false, true, false)
DEMBUF_WALL_COPY(ResolveSideFrictionRolling, true, true, false)
#undef DEMBUF_PAIR_COPY
#undef DEMBUF_WALL_COPY

// The copy for these effects, of four in the order (none, friction, rolling, both).
template <class F>
F Pick(bool friction, bool rolling, const F (&copies)[4]) {
  return copies[(friction ? 1 : 0) + (rolling ? 2 : 0)];
}

}  // namespace

// Each calls the copy for this CPU (vector_copies.h), chosen at the first call.
void ResolveWallBatch(bool friction, bool rolling, BodyId wall, const WallBatchInputs& in,
                      WallBatch& batch) {
  using Copy = void (*)(const WallBatchInputs&, WallBatch&);
  static const Copy plate[4] = {
      DEMBUF_PICK_COPY(ResolvePlate), DEMBUF_PICK_COPY(ResolvePlateFriction),
      DEMBUF_PICK_COPY(ResolvePlateRolling), DEMBUF_PICK_COPY(ResolvePlateFrictionRolling)};
  static const Copy side[4] = {DEMBUF_PICK_COPY(ResolveSide), DEMBUF_PICK_COPY(ResolveSideFriction),
                               DEMBUF_PICK_COPY(ResolveSideRolling),
                               DEMBUF_PICK_COPY(ResolveSideFrictionRolling)};
  Pick(friction, rolling, wall == kPlate ? plate : side)(in, batch);
}

void ResolvePairBatch(bool friction, bool rolling, const PairBatchInputs& in, PairBatch& batch) {
  using Copy = void (*)(const PairBatchInputs&, PairBatch&);
  static const Copy copies[4] = {
      DEMBUF_PICK_COPY(ResolvePairs), DEMBUF_PICK_COPY(ResolvePairsFriction),
      DEMBUF_PICK_COPY(ResolvePairsRolling), DEMBUF_PICK_COPY(ResolvePairsFrictionRolling)};
  Pick(friction, rolling, copies)(in, batch);
}

}  // namespace dembuf::dem::detail
