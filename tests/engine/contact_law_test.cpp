// The contact law alone (its parts' arithmetic, ResolveContact, the one copy every contact goes
// through), without the engine: a head-on elastic collision integrated with it against Hertz's
// closed form, and the Coulomb cap and the tangent-plane history on single calls.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "dembuf/core/contact_law.h"
#include "engine/two_body.h"

namespace dembuf::test {
namespace {

// The paper's glass: E = 5 GPa, nu = 0.22, two beads of 4.5 mm.
dem::PairParams GlassPair(double damping_A_s, double friction) {
  const dem::Elastic glass{5.0e9, 0.22};
  return dem::MakePairParams(dem::EffectiveModuli(glass, glass, dem::ShearStiffness::kPaper),
                             damping_A_s, friction);
}

TEST(ContactLaw, ElasticHeadOnCollisionMatchesHertzWithinHalfAPercent) {
  const double radius = 2.25e-3, mass = 2650.0 * 4.0 / 3.0 * std::numbers::pi * std::pow(radius, 3);
  const double reduced_mass = 0.5 * mass, v = 1.0;
  const dem::PairParams p = GlassPair(0.0, 0.5);
  const double sqrt_r_star = std::sqrt(0.5 * radius);
  const HertzImpact hertz(p.kn_per_sqrt_r * sqrt_r_star, reduced_mass, v);

  // The relative motion m* x'' = -Fn(x, x') by velocity Verlet, 20,000 steps a contact.
  const double h = hertz.duration / 20000.0;
  const double r_star = 0.5 * radius;
  double x = 0.0, u = v, t = 0.0, peak_force = 0.0, peak_overlap = 0.0;
  auto force = [&](double overlap, double rate) {
    if (overlap <= 0.0) return 0.0;
    return dem::HertzNormal::Force(overlap, rate, r_star, p);
  };
  double f = force(x, u);
  while (!(x <= 0.0 && u < 0.0) && t < 2.0 * hertz.duration) {
    const double u_half = u - 0.5 * h * f / reduced_mass;
    x += h * u_half;
    f = force(x, u_half);
    u = u_half - 0.5 * h * f / reduced_mass;
    t += h;
    peak_force = std::max(peak_force, f);
    peak_overlap = std::max(peak_overlap, x);
  }
  EXPECT_NEAR(peak_force / hertz.max_force, 1.0, 0.005);
  EXPECT_NEAR(peak_overlap / hertz.max_overlap, 1.0, 0.005);
  EXPECT_NEAR(t / hertz.duration, 1.0, 0.005);
  EXPECT_NEAR(-u / v, 1.0, 0.005) << "an elastic contact gives back its energy";
}

TEST(ContactLaw, NeverPullsAndCapsTheSpringAtCoulomb) {
  const dem::PairParams p = GlassPair(2.5e-6, 0.5);
  // The law with friction, as the force pass runs it.
  using Friction =
      dem::Effects<dem::Parts::Bit<dem::HertzNormal>() | dem::Parts::Bit<dem::MindlinTangential>()>;
  auto law = [&](const dem::ContactLane& c, double dt) {
    return dem::ResolveContact<Friction>(c, {p, 0.0, dt});
  };
  dem::ContactLane c{};
  c.nz = 1.0;
  c.overlap = 1e-6;
  c.r_star = 1.125e-3;
  // Parting fast: the damping term exceeds the elastic one, and the force is clamped at 0.
  c.approach_rate = -10.0;
  EXPECT_EQ(law(c, 1e-6).normal, 0.0);

  // At rest with a long stored spring in the tangent plane: the force is capped at mu Fn and
  // the spring shortened to what the cap supports.
  c.approach_rate = 0.0;
  c.hx = 1e-3;
  const dem::ContactResult out = law(c, 1e-6);
  const double tangential = std::hypot(out.fx, out.fy, out.fz - out.normal);
  EXPECT_NEAR(tangential, 0.5 * out.normal, 1e-12 * out.normal);
  const double ks_x = p.ks_per_sqrt_r * std::sqrt(c.r_star) * std::sqrt(c.overlap);
  EXPECT_NEAR(out.hx, 0.5 * out.normal / ks_x, 1e-12 * out.hx);

  // A history with a normal part is turned into the tangent plane with its length kept.
  dem::ContactLane tilted = c;
  tilted.hx = 3e-9;
  tilted.hz = 4e-9;
  const dem::ContactResult turned = law(tilted, 0.0);
  EXPECT_EQ(turned.hz, 0.0);
  EXPECT_NEAR(turned.hx, 5e-9, 1e-21);
}

}  // namespace
}  // namespace dembuf::test
