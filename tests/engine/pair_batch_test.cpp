// The batched (vectorized) contact law, for bead pairs and for beads against the plate and the
// side wall, gives the same bits as the contact-by-contact law it replaces, in every branch of
// the law: sticking, sliding, a history to turn into the tangent plane, a history along the
// normal (nothing left to turn), none at all, and a normal force clamped to zero by a fast
// separation.
#include <gtest/gtest.h>

#include <bit>
#include <cstdint>
#include <random>

#include "contact_kernels.h"
#include "pair_batch.h"

namespace dembuf::dem::detail {
namespace {

// A contact's history, by turns: none, small (sticks), large (slides), or along the normal n.
dem::Vec3 SomeHistory(int k, const dem::Vec3& n, std::mt19937& rng) {
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  switch (k % 4) {
    case 0:
      return dem::Vec3::Zero();
    case 1:
      return 3e-6 * dem::Vec3(unit(rng), unit(rng), unit(rng));
    case 2:
      return 1e-4 * dem::Vec3(unit(rng), unit(rng), unit(rng));
    default:
      return 1e-6 * n;
  }
}

// Two beads per contact (bead 2c touches bead 2c + 1), one list entry per contact.
struct Contacts {
  std::vector<dem::Vec3> position, velocity, angular_velocity, shear;
  std::vector<double> radius, r_star;
};

Contacts RandomContacts(int count, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(-1.0, 1.0), share(0.0, 1.0);
  Contacts c;
  for (int k = 0; k < count; ++k) {
    const double ri = 0.001 * (1.0 + share(rng)), rj = 0.001 * (1.0 + share(rng));
    dem::Vec3 n(unit(rng), unit(rng), unit(rng));
    n.normalize();
    const double overlap = 0.03 * ri * share(rng) + 1e-9;
    const dem::Vec3 xi(unit(rng), unit(rng), unit(rng));
    c.position.push_back(xi);
    c.position.push_back(xi - (ri + rj - overlap) * n);
    c.radius.push_back(ri);
    c.radius.push_back(rj);
    c.r_star.push_back(ri * rj / (ri + rj));
    // Speeds up to 5 m/s: some pairs separate fast enough to clamp the normal force to 0.
    for (int b = 0; b < 2; ++b) {
      c.velocity.push_back(5.0 * dem::Vec3(unit(rng), unit(rng), unit(rng)));
      c.angular_velocity.push_back(3000.0 * dem::Vec3(unit(rng), unit(rng), unit(rng)));
    }
    c.shear.push_back(SomeHistory(k, n, rng));
  }
  return c;
}

bool SameBits(double a, double b) {
  return std::bit_cast<std::uint64_t>(a) == std::bit_cast<std::uint64_t>(b);
}

void ExpectSameBits(const dem::Vec3& batched, const dem::Vec3& reference, const char* what, int k) {
  for (int d = 0; d < 3; ++d) {
    EXPECT_TRUE(SameBits(batched[d], reference[d]))
        << what << " of contact " << k << ", component " << d << ": " << batched[d] << " vs "
        << reference[d];
  }
}

// Rolling resistance mu_r of the tests with it: a tenth of a radius, so that both of its
// limits (mu_r R* Fn, and the torque that stops the rolling within a step) are met.
constexpr double kRollingFriction = 0.1;

// The contact parts of a world with friction and rolling resistance or without.
PartMask ContactParts(bool friction, bool rolling) {
  return Parts::Bit<HertzNormal>() | (friction ? Parts::Bit<MindlinTangential>() : 0) |
         (rolling ? Parts::Bit<RollingResistance>() : 0);
}

// The vector form of the law (Resolve) for these parts.
ContactOutcome ScalarLaw(bool friction, bool rolling, const dem::ContactGeometry& g, double ai,
                         double aj, const dem::PairParams& params, double dt, dem::Vec3& shear,
                         const SpinPair& pair) {
  ContactOutcome out;
  WithEffects<Stage::kContact>(ContactParts(friction, rolling), [&]<class E>(E) {
    out = Resolve<E>(g, ai, aj, {params, kRollingFriction, dt}, shear, pair);
  });
  return out;
}

// Glass beads' masses for the radii.
std::vector<double> Masses(const std::vector<double>& radius) {
  std::vector<double> mass;
  for (double r : radius) mass.push_back(2500.0 * 4.0 / 3.0 * 3.14159265358979 * r * r * r);
  return mass;
}

void CompareWithScalarLaw(bool friction, bool rolling) {
  // A full batch but one: not a multiple of any vector width, so the loop's tail runs too.
  constexpr int kCount = PairBatch::kTarget - 1;
  Contacts c = RandomContacts(kCount, friction ? 7u : 8u);
  const dem::PairParams params{4.0 / 3.0 * 3.5e10, 8.0 * 1.2e10, 2e-6, 0.5};
  const double dt = 2e-7;

  PairBatch batch;
  for (int k = 0; k < kCount; ++k) {
    batch.bead[k] = 2 * k;
    batch.partner[k] = 2 * k + 1;
    batch.entry[k] = k;
  }
  batch.size = kCount;
  const std::vector<double> mass = Masses(c.radius);
  // A third of the pairs roll slowly, so that rolling resistance stops them within the step.
  if (rolling)
    for (int k = 0; k < kCount; k += 3) {
      c.angular_velocity[2 * k] *= 1e-3;
      c.angular_velocity[2 * k + 1] *= 1e-3;
    }
  const PairBatchInputs inputs{c.position.front().data(),
                               c.velocity.front().data(),
                               c.angular_velocity.front().data(),
                               c.radius.data(),
                               mass.data(),
                               c.shear.front().data(),
                               {params, kRollingFriction, dt},
                               nullptr,  // one species: no table read
                               nullptr,
                               0};
  ResolvePairBatch(ContactParts(friction, rolling), inputs, batch);
  int rolling_limited = 0, rolling_stopped = 0;

  int sliding = 0, sticking_with_history = 0, clamped = 0;
  for (int k = 0; k < kCount; ++k) {
    const int i = 2 * k, j = 2 * k + 1;
    const dem::Vec3 d = c.position[i] - c.position[j];
    const double dist = std::sqrt(d.squaredNorm());
    const double overlap = c.radius[i] + c.radius[j] - dist;
    const dem::Vec3 normal = d * (1.0 / dist);
    const double ai = LeverArm(c.radius[i], overlap), aj = LeverArm(c.radius[j], overlap);
    const dem::Vec3 w_arm = friction
                                ? dem::Vec3(ai * c.angular_velocity[i] + aj * c.angular_velocity[j])
                                : dem::Vec3::Zero();
    const dem::ContactGeometry g =
        MakeGeometry(normal, overlap, c.velocity[i] - c.velocity[j], w_arm, c.r_star[k]);
    dem::Vec3 shear = c.shear[k];
    const SpinPair pair{c.angular_velocity[i] - c.angular_velocity[j],
                        1.0 / (ParticleState::InverseSphereInertia(mass[i], c.radius[i]) +
                               ParticleState::InverseSphereInertia(mass[j], c.radius[j]))};
    const ContactOutcome out = ScalarLaw(friction, rolling, g, ai, aj, params, dt, shear, pair);
    if (rolling && out.normal > 0.0) {
      dem::Vec3 spring = c.shear[k];  // (the call above advanced `shear`)
      const ContactOutcome without =
          ScalarLaw(friction, false, g, ai, aj, params, dt, spring, pair);
      const double torque = (out.torque_i - without.torque_i).norm();
      rolling_limited += torque >= 0.999999 * kRollingFriction * c.r_star[k] * out.normal;
      rolling_stopped +=
          torque > 0.0 && torque < 0.99 * kRollingFriction * c.r_star[k] * out.normal;
    }
    sliding += friction && out.force.squaredNorm() > 0.0 &&
               (out.force - out.normal * normal).norm() >= 0.999999 * params.friction * out.normal;
    clamped += out.normal == 0.0;
    sticking_with_history +=
        friction && out.normal > 0.0 && c.shear[k] != dem::Vec3::Zero() &&
        (out.force - out.normal * normal).norm() < 0.99 * params.friction * out.normal;

    EXPECT_TRUE(SameBits(batch.overlap[k], overlap)) << "overlap of contact " << k;
    ExpectSameBits(dem::Vec3(batch.force[0][k], batch.force[1][k], batch.force[2][k]), out.force,
                   "force", k);
    if (friction || rolling) {
      ExpectSameBits(
          dem::Vec3(batch.torque_bead[0][k], batch.torque_bead[1][k], batch.torque_bead[2][k]),
          out.torque_i, "torque on the bead", k);
      ExpectSameBits(dem::Vec3(batch.torque_partner[0][k], batch.torque_partner[1][k],
                               batch.torque_partner[2][k]),
                     out.torque_j, "torque on the partner", k);
    }
    if (friction)
      ExpectSameBits(dem::Vec3(batch.shear[0][k], batch.shear[1][k], batch.shear[2][k]), shear,
                     "history", k);
  }
  // Rolling resistance meets both of its limits in the set.
  if (rolling) {
    EXPECT_GT(rolling_limited, kCount / 20);
    EXPECT_GT(rolling_stopped, kCount / 20);
  }
  // The random set exercises the law's branches (counted with the scalar law).
  if (friction) {
    EXPECT_GT(sliding, kCount / 10);
    EXPECT_GT(sticking_with_history, kCount / 10);
  }
  EXPECT_GT(clamped, kCount / 20);
}

TEST(PairBatch, FrictionalLawGivesTheScalarLawsBits) {
  CompareWithScalarLaw(true, false);
}

TEST(PairBatch, FrictionlessLawGivesTheScalarLawsBits) {
  CompareWithScalarLaw(false, false);
}

TEST(PairBatch, RollingResistanceGivesTheScalarLawsBits) {
  CompareWithScalarLaw(true, true);
  CompareWithScalarLaw(false, true);
}

// Beads pressed into the plate (even ones) or the side wall (odd ones: half of them into its
// face, half onto its rim from above), one contact each, with the histories of SomeHistory: the
// batched wall law against ContainerContacts' arithmetic (MakeGeometry and Resolve with the wall's
// normal, lever arm 0 on the wall's side).
void CompareWallsWithScalarLaw(bool friction, bool rolling) {
  // A full batch on the plate, all but one on the side wall (the vector loop's tail).
  constexpr int kCount = 2 * WallBatch::kTarget - 1;
  const dem::Container box{0.05, 0.1};
  std::mt19937 rng(friction ? 9u : 10u);
  std::uniform_real_distribution<double> unit(-1.0, 1.0), share(0.0, 1.0);
  std::vector<dem::Vec3> position, velocity, angular_velocity, shear;
  std::vector<double> radius;
  for (int k = 0; k < kCount; ++k) {
    const double r = 0.001 * (1.0 + share(rng));
    const double overlap = 0.03 * r * share(rng) + 1e-9;
    if (k % 2 == 0) {
      position.emplace_back(0.03 * unit(rng), 0.03 * unit(rng), r - overlap);
      shear.push_back(SomeHistory(k / 2, dem::Vec3::UnitZ(), rng));
    } else if (k % 4 == 1) {
      const double angle = 3.14159 * unit(rng), rho = box.radius_m - r + overlap;
      position.emplace_back(rho * std::cos(angle), rho * std::sin(angle), 0.09 * share(rng));
      shear.push_back(SomeHistory(k / 2, -position.back().normalized(), rng));
    } else {
      // Above the wall, touching its rim from a direction at `tilt` from the outward radial.
      const double angle = 3.14159 * unit(rng), tilt = 0.05 + 3.04 * share(rng);
      const double reach = r - overlap;
      const double rho = box.radius_m + reach * std::cos(tilt);
      position.emplace_back(rho * std::cos(angle), rho * std::sin(angle),
                            box.height_m + reach * std::sin(tilt));
      const dem::Vec3 normal(std::cos(tilt) * std::cos(angle), std::cos(tilt) * std::sin(angle),
                             std::sin(tilt));
      shear.push_back(SomeHistory(k / 2, normal, rng));
    }
    radius.push_back(r);
    velocity.push_back(5.0 * dem::Vec3(unit(rng), unit(rng), unit(rng)));
    angular_velocity.push_back(3000.0 * dem::Vec3(unit(rng), unit(rng), unit(rng)));
  }
  // Damping strong enough that the fastest separations clamp the normal force to 0.
  const dem::PairParams params{4.0 / 3.0 * 6.0e10, 8.0 * 2.0e10, 4e-6, 0.3};
  const double dt = 2e-7;
  // The histories are kept per slot, not per bead: here bead k's is in slot kCount - 1 - k.
  std::vector<dem::Vec3> shear_by_slot(shear.rbegin(), shear.rend());
  const std::vector<double> mass = Masses(radius);
  const WallBatchInputs inputs{position.front().data(),
                               velocity.front().data(),
                               angular_velocity.front().data(),
                               radius.data(),
                               mass.data(),
                               shear_by_slot.front().data(),
                               {params, kRollingFriction, dt},
                               box,
                               nullptr,  // one species: no table read
                               nullptr};

  int clamped = 0, sliding = 0;
  for (const dem::BodyId wall : {dem::kPlate, dem::kSideWall}) {
    const int parity = wall == dem::kPlate ? 0 : 1;
    WallBatch batch;
    batch.size = 0;
    for (int k = parity; k < kCount; k += 2) {
      batch.bead[batch.size] = k;
      batch.slot[batch.size++] = kCount - 1 - k;
    }
    ResolveWallBatch(ContactParts(friction, rolling), wall, inputs, batch);

    for (std::size_t c = 0; c < batch.size; ++c) {
      const int k = static_cast<int>(batch.bead[c]);
      const double r = radius[k];
      double overlap = r - position[k].z();
      dem::Vec3 normal = dem::Vec3::UnitZ();
      if (wall == dem::kSideWall) {
        ASSERT_TRUE(SideWallContact(box, position[k], r, overlap, normal));
      }
      const double arm = LeverArm(r, overlap);
      const dem::ContactGeometry g =
          MakeGeometry(normal, overlap, velocity[k], arm * angular_velocity[k], r);
      dem::Vec3 history = shear[k];
      const SpinPair pair{angular_velocity[k],
                          1.0 / ParticleState::InverseSphereInertia(mass[k], r)};
      const ContactOutcome out =
          ScalarLaw(friction, rolling, g, arm, 0.0, params, dt, history, pair);
      clamped += out.normal == 0.0;
      sliding +=
          friction && out.normal > 0.0 &&
          (out.force - out.normal * normal).norm() >= 0.999999 * params.friction * out.normal;
      EXPECT_TRUE(SameBits(batch.overlap[c], overlap)) << "overlap of bead " << k;
      EXPECT_TRUE(SameBits(batch.normal_force[c], out.normal)) << "normal force of bead " << k;
      ExpectSameBits(dem::Vec3(batch.force[0][c], batch.force[1][c], batch.force[2][c]), out.force,
                     "force", k);
      if (friction || rolling)
        ExpectSameBits(dem::Vec3(batch.torque[0][c], batch.torque[1][c], batch.torque[2][c]),
                       out.torque_i, "torque", k);
      if (friction)
        ExpectSameBits(dem::Vec3(batch.shear[0][c], batch.shear[1][c], batch.shear[2][c]), history,
                       "history", k);
    }
  }
  EXPECT_GT(clamped, kCount / 20);
  if (friction) {
    EXPECT_GT(sliding, kCount / 10);
  }
}

TEST(WallBatch, FrictionalLawGivesTheScalarLawsBits) {
  CompareWallsWithScalarLaw(true, false);
}

TEST(WallBatch, FrictionlessLawGivesTheScalarLawsBits) {
  CompareWallsWithScalarLaw(false, false);
}

TEST(WallBatch, RollingResistanceGivesTheScalarLawsBits) {
  CompareWallsWithScalarLaw(true, true);
  CompareWallsWithScalarLaw(false, true);
}

}  // namespace
}  // namespace dembuf::dem::detail
