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

// Contact c (one lane of a vectorized loop): the slip from MakeGeometry's expression, then the
// contact parts of E (ResolveContact, the one copy of their arithmetic), whose results go to
// the batch's arrays. The lane `g` has the geometry, the lever arms and, for parts that read
// spin, w_bead - w_partner and the pair's inertia; `w_arm` = ai w_bead + aj w_partner. The
// contact's history before this step is history[3 k .. 3 k + 2] (indexed here, not through a
// pointer to it: that form gathers). `g` is the loop's own, completed here: a copy of it kept
// GCC 12 from vectorizing the loop at all (1.6 times slower with friction).
template <class E, Partner kPartner>
inline __attribute__((always_inline)) void ResolveLane(ContactLane& g, const double (&w_arm)[3],
                                                       const double (&v)[3],
                                                       const ContactConstants& constants,
                                                       const double* history, std::size_t k,
                                                       const LawResults& out, std::size_t c) {
  const double nx = g.nx, ny = g.ny, nz = g.nz;
  g.approach_rate = -(v[0] * nx + v[1] * ny + v[2] * nz);
  if constexpr (E::kSlip) {
    const double approach = g.approach_rate;
    g.sx = (v[0] + approach * nx) - (w_arm[1] * nz - w_arm[2] * ny);
    g.sy = (v[1] + approach * ny) - (w_arm[2] * nx - w_arm[0] * nz);
    g.sz = (v[2] + approach * nz) - (w_arm[0] * ny - w_arm[1] * nx);
    g.hx = history[3 * k];
    g.hy = history[3 * k + 1];
    g.hz = history[3 * k + 2];
  } else {
    g.sx = g.sy = g.sz = g.hx = g.hy = g.hz = 0.0;
  }
  const ContactResult r = ResolveContact<E>(g, constants);
  if constexpr (kPartner == Partner::kWall) out.normal_force[c] = r.normal;
  out.fx[c] = r.fx;
  out.fy[c] = r.fy;
  out.fz[c] = r.fz;
  if constexpr (E::kHistory) {
    out.hx[c] = r.hx;
    out.hy[c] = r.hy;
    out.hz[c] = r.hz;
  }
  if constexpr (E::kRotate) {
    out.tix[c] = r.tix;
    out.tiy[c] = r.tiy;
    out.tiz[c] = r.tiz;
    if constexpr (kPartner == Partner::kBead) {
      out.tjx[c] = r.tjx;
      out.tjy[c] = r.tjy;
      out.tjz[c] = r.tjz;
    }
  }
}

// Bead pairs, one contact per loop iteration (the loop vectorizes: gathers of both beads'
// state, vector square roots and divisions, masks for the law's branches).
template <class E>
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
  // A copy: the stores to the result arrays could otherwise alias it.
  const ContactConstants constants = in.constants;
  const std::size_t n = batch.size;

#pragma omp simd
  for (std::size_t c = 0; c < n; ++c) {
    const std::size_t i = bead[c], j = partner[c];
    // Normal from j to i, overlap, lever arms.
    const double dx = x[3 * i] - x[3 * j], dy = x[3 * i + 1] - x[3 * j + 1],
                 dz = x[3 * i + 2] - x[3 * j + 2];
    const double ri = radius[i], rj = radius[j];
    const double dist = std::sqrt(dx * dx + dy * dy + dz * dz);
    ContactLane g;
    g.overlap = (ri + rj) - dist;
    const double inv_dist = 1.0 / dist;
    g.nx = dx * inv_dist;
    g.ny = dy * inv_dist;
    g.nz = dz * inv_dist;
    g.ai = ri - 0.5 * g.overlap;
    g.aj = rj - 0.5 * g.overlap;
    const double v_rel[3] = {v[3 * i] - v[3 * j], v[3 * i + 1] - v[3 * j + 1],
                             v[3 * i + 2] - v[3 * j + 2]};
    double w_arm[3] = {0.0, 0.0, 0.0};
    if constexpr (E::kSlip)
      for (int d = 0; d < 3; ++d) w_arm[d] = g.ai * w[3 * i + d] + g.aj * w[3 * j + d];
    g.r_star = EffectiveRadius(ri, rj);
    if constexpr (E::kSpin) {
      g.wx = w[3 * i] - w[3 * j];
      g.wy = w[3 * i + 1] - w[3 * j + 1];
      g.wz = w[3 * i + 2] - w[3 * j + 2];
      g.inertia = 1.0 / (ParticleState::InverseSphereInertia(mass[i], ri) +
                         ParticleState::InverseSphereInertia(mass[j], rj));
    } else {
      g.wx = g.wy = g.wz = g.inertia = 0.0;
    }
    overlap_out[c] = g.overlap;
    if constexpr (E::kSpecies) {
      ContactConstants pair = constants;
      pair.pair = in.pair_table[in.species_count * in.species[i] + in.species[j]];
      ResolveLane<E, Partner::kBead>(g, w_arm, v_rel, pair, shear, entry[c], out, c);
    } else {
      ResolveLane<E, Partner::kBead>(g, w_arm, v_rel, constants, shear, entry[c], out, c);
    }
  }
}

// Beads against the plate (kOnPlate) or the side wall, one contact per loop iteration, as the
// projectile's contacts with them are resolved: the wall does not move and takes no torque
// (aj = 0).
template <class E, bool kOnPlate>
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
  const ContactConstants constants = in.constants;
  const Container box = in.box;
  const std::size_t n = batch.size;

#pragma omp simd
  for (std::size_t c = 0; c < n; ++c) {
    const std::size_t i = bead[c];
    const double r = radius[i];
    ContactLane g;
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
    const double v_rel[3] = {v[3 * i], v[3 * i + 1], v[3 * i + 2]};
    const double w_arm[3] = {g.ai * w[3 * i], g.ai * w[3 * i + 1], g.ai * w[3 * i + 2]};
    g.r_star = r;
    if constexpr (E::kSpin) {
      g.wx = w[3 * i];
      g.wy = w[3 * i + 1];
      g.wz = w[3 * i + 2];
      g.inertia = 1.0 / ParticleState::InverseSphereInertia(mass[i], r);
    } else {
      g.wx = g.wy = g.wz = g.inertia = 0.0;
    }
    overlap_out[c] = g.overlap;
    if constexpr (E::kSpecies) {
      ContactConstants pair = constants;
      pair.pair = in.wall_table[in.species[i]];
      ResolveLane<E, Partner::kWall>(g, w_arm, v_rel, pair, shear, slot[c], out, c);
    } else {
      ResolveLane<E, Partner::kWall>(g, w_arm, v_rel, constants, shear, slot[c], out, c);
    }
  }
}

// Each kind of contact for each instance of the contact parts (parts.h), each compiled for
// several instruction sets.
DEMBUF_VECTOR_COPIES_OF(void, ResolvePairs, (const PairBatchInputs& in, PairBatch& batch),
                        (ResolveBody<E>(in, batch)))
DEMBUF_VECTOR_COPIES_OF(void, ResolvePlate, (const WallBatchInputs& in, WallBatch& batch),
                        (ResolveWallBody<E, true>(in, batch)))
DEMBUF_VECTOR_COPIES_OF(void, ResolveSide, (const WallBatchInputs& in, WallBatch& batch),
                        (ResolveWallBody<E, false>(in, batch)))

}  // namespace

// Each calls the instance for the world's parts in the copy for this CPU (vector_copies.h),
// chosen at the first call.
void ResolveWallBatch(PartMask active, BodyId wall, const WallBatchInputs& in, WallBatch& batch) {
  static const auto plate = InstanceTable<Stage::kContact>(
      []<class E>(E) { return DEMBUF_PICK_COPY_OF(ResolvePlate, E); });
  static const auto side = InstanceTable<Stage::kContact>(
      []<class E>(E) { return DEMBUF_PICK_COPY_OF(ResolveSide, E); });
  const std::size_t instance = detail::InstanceIndex<Stage::kContact>(active);
  (wall == kPlate ? plate : side)[instance](in, batch);
}

void ResolvePairBatch(PartMask active, const PairBatchInputs& in, PairBatch& batch) {
  static const auto copies = InstanceTable<Stage::kContact>(
      []<class E>(E) { return DEMBUF_PICK_COPY_OF(ResolvePairs, E); });
  copies[detail::InstanceIndex<Stage::kContact>(active)](in, batch);
}

}  // namespace dembuf::dem::detail
