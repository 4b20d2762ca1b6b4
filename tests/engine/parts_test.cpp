// The physics parts' list (parts.h) and what is derived from it: which parts a world calls for,
// the instances each stage's kernels are compiled for, and the choice of one at run time. The
// instance checks cover a part added to the list without a line changed here; the worlds below
// name today's parts.
#include <gtest/gtest.h>

#include <bit>
#include <set>

#include "dembuf/core/parts/parts.h"
#include "dembuf/core/simulation.h"

namespace dembuf::dem {
namespace {

constexpr PartMask kHertz = Parts::Bit<HertzNormal>();
constexpr PartMask kMindlin = Parts::Bit<MindlinTangential>();
constexpr PartMask kRolling = Parts::Bit<RollingResistance>();
constexpr PartMask kRotation = Parts::Bit<BodyRotation>();
constexpr PartMask kDamping = Parts::Bit<LocalViscousDamping>();

WorldParams World(double friction, double rolling, double local_alpha) {
  WorldParams w;
  w.sphere_pair = {1.0, 1.0, 0.0, friction};
  w.sphere_wall = {1.0, 1.0, 0.0, 0.0};
  w.rolling_friction = rolling;
  w.bead_damping.local_alpha = local_alpha;
  return w;
}

TEST(Parts, AWorldCallsForThePartsItsParametersTurnOn) {
  EXPECT_EQ(ActiveParts(World(0.0, 0.0, 0.0)), kHertz) << "the law's base alone";
  EXPECT_EQ(ActiveParts(World(0.5, 0.0, 0.0)), kHertz | kMindlin | kRotation);
  EXPECT_EQ(ActiveParts(World(0.0, 0.1, 0.0)), kHertz | kRolling | kRotation);
  EXPECT_EQ(ActiveParts(World(0.0, 0.0, 0.2)), kHertz | kDamping) << "damping turns nothing";
  WorldParams wall_friction = World(0.0, 0.0, 0.0);
  wall_friction.sphere_wall.friction = 0.3;
  EXPECT_EQ(ActiveParts(wall_friction), kHertz | kMindlin | kRotation);
}

TEST(Parts, BodiesTurnExactlyWhenAPartGivesThemTorques) {
  for (PartMask world = 0; world < (PartMask{1} << 5); ++world) {
    WorldParams w = World(world & 1 ? 0.5 : 0.0, world & 2 ? 0.1 : 0.0, world & 4 ? 0.2 : 0.0);
    w.bead_damping.viscous_rate_per_s = world & 8 ? 10.0 : 0.0;
    w.sphere_wall.friction = world & 16 ? 0.3 : 0.0;
    const PartMask active = ActiveParts(w);
    EXPECT_EQ((active & kRotation) != 0, (active & detail::kTurningParts) != 0)
        << "world " << world;
  }
}

// Every instance of a stage is a distinct set of that stage's parts holding its base, and the
// run-time choice finds the instance of exactly the world's parts of the stage.
template <Stage S>
void CheckInstances() {
  std::set<PartMask> seen;
  for (std::size_t k = 0; k < detail::kInstances<S>; ++k) {
    const PartMask instance = detail::InstanceParts<S>(k);
    EXPECT_EQ(instance & ~detail::kPartsOfStage<S>, 0u) << "instance " << k << " of another stage";
    EXPECT_EQ(instance & detail::kAlwaysOnParts, detail::kPartsOfStage<S> & detail::kAlwaysOnParts);
    EXPECT_EQ(detail::InstanceIndex<S>(instance), k);
    // Parts of other stages do not change the choice.
    EXPECT_EQ(detail::InstanceIndex<S>(instance | ~detail::kPartsOfStage<S>), k);
    seen.insert(instance);
  }
  EXPECT_EQ(seen.size(), detail::kInstances<S>);
  EXPECT_EQ(detail::kInstances<S>, std::size_t{1} << std::popcount(detail::kOptionalParts<S>));
}

TEST(Parts, EachStageHasOneInstanceForEverySetOfItsParts) {
  CheckInstances<Stage::kContact>();
  CheckInstances<Stage::kMotion>();
  EXPECT_EQ(detail::kPartsOfStage<Stage::kContact> | detail::kPartsOfStage<Stage::kMotion>,
            (PartMask{1} << Parts::kCount) - 1)
      << "every part acts in one of the stages";
}

TEST(Parts, AnInstanceAsksWhatItsPartsNeed) {
  using Frictionless = Effects<kHertz>;
  static_assert(!Frictionless::kRotate && !Frictionless::kSlip && !Frictionless::kHistory &&
                !Frictionless::kSpin);
  using Friction = Effects<kHertz | kMindlin>;
  static_assert(Friction::kRotate && Friction::kSlip && Friction::kHistory && !Friction::kSpin);
  using Rolling = Effects<kHertz | kRolling>;
  static_assert(Rolling::kRotate && !Rolling::kSlip && !Rolling::kHistory && Rolling::kSpin);
  using Damped = Effects<kDamping>;
  static_assert(Damped::kShapedAcceleration && !Damped::kRotate);
  static_assert(std::is_same_v<AccelerationPart<Damped>, LocalViscousDamping>);
  static_assert(std::is_void_v<AccelerationPart<Effects<kRotation>>>);
  // The dispatch calls the instance of the world's parts.
  int called = 0;
  WithEffects<Stage::kContact>(kHertz | kRolling | kRotation | kDamping, [&]<class E>(E) {
    EXPECT_EQ(E::kParts, kHertz | kRolling);
    ++called;
  });
  WithEffects<Stage::kMotion>(kHertz | kRolling | kRotation | kDamping, [&]<class E>(E) {
    EXPECT_EQ(E::kParts, kRotation | kDamping);
    ++called;
  });
  EXPECT_EQ(called, 2);
}

}  // namespace
}  // namespace dembuf::dem
