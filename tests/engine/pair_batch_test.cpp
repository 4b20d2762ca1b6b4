// The batched (vectorized) contact law gives the same bits as the contact-by-contact law it
// replaces, in every branch of the law: sticking, sliding, a history to turn into the tangent
// plane, a history along the normal (nothing left to turn), none at all, and a normal force
// clamped to zero by a fast separation.
#include <gtest/gtest.h>

#include <bit>
#include <cstdint>
#include <random>

#include "contact_kernels.h"
#include "pair_batch.h"

namespace dembuf::detail {
namespace {

// Two beads per contact (bead 2c touches bead 2c + 1), one list entry per contact.
struct Contacts {
  std::vector<Vec3> position, velocity, angular_velocity, shear;
  std::vector<double> radius, sqrt_r_star;
};

Contacts RandomContacts(int count, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(-1.0, 1.0), share(0.0, 1.0);
  Contacts c;
  for (int k = 0; k < count; ++k) {
    const double ri = 0.001 * (1.0 + share(rng)), rj = 0.001 * (1.0 + share(rng));
    Vec3 n(unit(rng), unit(rng), unit(rng));
    n.normalize();
    const double overlap = 0.03 * ri * share(rng) + 1e-9;
    const Vec3 xi(unit(rng), unit(rng), unit(rng));
    c.position.push_back(xi);
    c.position.push_back(xi - (ri + rj - overlap) * n);
    c.radius.push_back(ri);
    c.radius.push_back(rj);
    c.sqrt_r_star.push_back(std::sqrt(ri * rj / (ri + rj)));
    // Speeds up to 5 m/s: some pairs separate fast enough to clamp the normal force to 0.
    for (int b = 0; b < 2; ++b) {
      c.velocity.push_back(5.0 * Vec3(unit(rng), unit(rng), unit(rng)));
      c.angular_velocity.push_back(3000.0 * Vec3(unit(rng), unit(rng), unit(rng)));
    }
    // Histories: none, small (sticks), large (slides), or along the normal.
    switch (k % 4) {
      case 0:
        c.shear.push_back(Vec3::Zero());
        break;
      case 1:
        c.shear.push_back(3e-6 * Vec3(unit(rng), unit(rng), unit(rng)));
        break;
      case 2:
        c.shear.push_back(1e-4 * Vec3(unit(rng), unit(rng), unit(rng)));
        break;
      default:
        c.shear.push_back(1e-6 * n);
        break;
    }
  }
  return c;
}

bool SameBits(double a, double b) {
  return std::bit_cast<std::uint64_t>(a) == std::bit_cast<std::uint64_t>(b);
}

void ExpectSameBits(const Vec3& batched, const Vec3& reference, const char* what, int k) {
  for (int d = 0; d < 3; ++d) {
    EXPECT_TRUE(SameBits(batched[d], reference[d]))
        << what << " of contact " << k << ", component " << d << ": " << batched[d] << " vs "
        << reference[d];
  }
}

void CompareWithScalarLaw(bool friction) {
  constexpr int kCount = 999;  // not a multiple of any vector width: the loop's tail runs too
  Contacts c = RandomContacts(kCount, friction ? 7u : 8u);
  const PairParams params{4.0 / 3.0 * 3.5e10, 8.0 * 1.2e10, 2e-6, 0.5};
  const double dt = 2e-7;

  PairBatch batch;
  batch.Reserve(kCount);
  for (int k = 0; k < kCount; ++k) {
    batch.bead[k] = 2 * k;
    batch.partner[k] = 2 * k + 1;
    batch.entry[k] = k;
  }
  batch.size = kCount;
  const PairBatchInputs inputs{c.position.front().data(),
                               c.velocity.front().data(),
                               c.angular_velocity.front().data(),
                               c.radius.data(),
                               c.sqrt_r_star.data(),
                               c.shear.front().data(),
                               params,
                               dt};
  ResolvePairBatch(friction, inputs, batch);

  int sliding = 0, sticking_with_history = 0, clamped = 0;
  for (int k = 0; k < kCount; ++k) {
    const int i = 2 * k, j = 2 * k + 1;
    const Vec3 d = c.position[i] - c.position[j];
    const double dist = std::sqrt(d.squaredNorm());
    const double overlap = c.radius[i] + c.radius[j] - dist;
    const Vec3 normal = d * (1.0 / dist);
    const double ai = LeverArm(c.radius[i], overlap), aj = LeverArm(c.radius[j], overlap);
    const Vec3 w_arm =
        friction ? Vec3(ai * c.angular_velocity[i] + aj * c.angular_velocity[j]) : Vec3::Zero();
    const ContactGeometry g =
        MakeGeometry(normal, overlap, c.velocity[i] - c.velocity[j], w_arm, c.sqrt_r_star[k]);
    Vec3 shear = c.shear[k];
    const ContactOutcome out = friction ? Resolve<true>(g, ai, aj, params, dt, shear)
                                        : Resolve<false>(g, ai, aj, params, dt, shear);
    sliding += friction && out.force.squaredNorm() > 0.0 &&
               (out.force - out.normal * normal).norm() >= 0.999999 * params.friction * out.normal;
    clamped += out.normal == 0.0;
    sticking_with_history +=
        friction && out.normal > 0.0 && c.shear[k] != Vec3::Zero() &&
        (out.force - out.normal * normal).norm() < 0.99 * params.friction * out.normal;

    EXPECT_TRUE(SameBits(batch.overlap[k], overlap)) << "overlap of contact " << k;
    ExpectSameBits(Vec3(batch.force[0][k], batch.force[1][k], batch.force[2][k]), out.force,
                   "force", k);
    if (friction) {
      ExpectSameBits(
          Vec3(batch.torque_bead[0][k], batch.torque_bead[1][k], batch.torque_bead[2][k]),
          out.torque_i, "torque on the bead", k);
      ExpectSameBits(
          Vec3(batch.torque_partner[0][k], batch.torque_partner[1][k], batch.torque_partner[2][k]),
          out.torque_j, "torque on the partner", k);
      ExpectSameBits(Vec3(batch.shear[0][k], batch.shear[1][k], batch.shear[2][k]), shear,
                     "history", k);
    }
  }
  // The random set exercises the law's branches (counted with the scalar law).
  if (friction) {
    EXPECT_GT(sliding, kCount / 10);
    EXPECT_GT(sticking_with_history, kCount / 10);
  }
  EXPECT_GT(clamped, kCount / 20);
}

TEST(PairBatch, FrictionalLawGivesTheScalarLawsBits) {
  CompareWithScalarLaw(true);
}

TEST(PairBatch, FrictionlessLawGivesTheScalarLawsBits) {
  CompareWithScalarLaw(false);
}

}  // namespace
}  // namespace dembuf::detail
