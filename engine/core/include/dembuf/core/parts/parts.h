// The model's physics parts, in one list, and what the kernels derive from it: which parts a
// world has (a bit each), the instances a stage's kernels are compiled for (every set of that
// stage's parts that can be on), and the run-time choice of one. Adding a mechanism is a header
// beside this one (part.h says what it holds), its scene rows (engine/study/src/scene/parts/)
// and one line in `Parts` below (docs/architecture.md walks through it); the kernels, their
// dispatch and their copies for each instruction set follow from the list.
#pragma once

#include <array>
#include <bit>
#include <cassert>
#include <cstddef>
#include <cstdint>
#include <type_traits>
#include <utility>

#include "dembuf/core/parts/bead_damping.h"
#include "dembuf/core/parts/hertz_normal.h"
#include "dembuf/core/parts/mindlin_tangential.h"
#include "dembuf/core/parts/rolling_resistance.h"
#include "dembuf/core/parts/species_pairs.h"

namespace dembuf::dem {

/// Beads turn: the kicks integrate their torques and angular velocities. Not a mechanism of its
/// own but what the parts that give torques (kTurnsBodies) need of the motion stage, so it is on
/// exactly when one of them is (ActiveParts); a world without them integrates no rotation.
struct BodyRotation {
  static constexpr Stage kStage = Stage::kMotion;
  static constexpr bool kFollowsTurningParts = true;
};

/// A set of parts, one bit each in the order of the list.
using PartMask = std::uint32_t;

template <class... P>
struct PartList {
  static_assert(sizeof...(P) <= 32, "one bit a part in a PartMask");
  static constexpr std::size_t kCount = sizeof...(P);

  /// The bit of part Q.
  template <class Q>
  static constexpr PartMask Bit() {
    static_assert((std::is_same_v<P, Q> || ...), "not a part of the list");
    PartMask bit = 0, index = 0;
    ((bit |= std::is_same_v<P, Q> ? PartMask{1} << index : 0, ++index), ...);
    return bit;
  }
  /// The bits of the parts for which `trait` is true.
  template <class Trait>
  static constexpr PartMask BitsWhere(Trait trait) {
    PartMask bits = 0, index = 0;
    ((bits |= trait(std::type_identity<P>{}) ? PartMask{1} << index : 0, ++index), ...);
    return bits;
  }
  /// The parts whose own switch is on in a world: the law's base always, the others by On.
  template <class World>
  static PartMask Switched(const World& world) {
    PartMask bits = 0, index = 0;
    ((bits |= (detail::AlwaysOn<P>() || CalledFor<P>(world)) ? PartMask{1} << index : 0, ++index),
     ...);
    return bits;
  }

 private:
  template <class Q, class World>
  static bool CalledFor(const World& world) {
    if constexpr (requires { Q::On(world); })
      return Q::On(world);
    else
      return false;
  }
};

/// The model's parts, in the order their arithmetic runs within a stage.
using Parts = PartList<HertzNormal, MindlinTangential, RollingResistance, SpeciesPairs,
                       BodyRotation, LocalViscousDamping>;

namespace detail {

/// Bits of the parts with a trait (detail::Name<P>()).
#define DEMBUF_PARTS_WHERE(expression) \
  Parts::BitsWhere([]<class P>(std::type_identity<P>) { return expression; })

constexpr PartMask kTurningParts = DEMBUF_PARTS_WHERE(detail::TurnsBodies<P>());
constexpr PartMask kFollowingParts = DEMBUF_PARTS_WHERE(detail::FollowsTurningParts<P>());
constexpr PartMask kRotatingParts = kTurningParts | kFollowingParts;
constexpr PartMask kSlipReadingParts = DEMBUF_PARTS_WHERE(detail::ReadsSlip<P>());
constexpr PartMask kHistoryKeepingParts = DEMBUF_PARTS_WHERE(detail::KeepsHistory<P>());
constexpr PartMask kSpinReadingParts = DEMBUF_PARTS_WHERE(detail::ReadsSpin<P>());
constexpr PartMask kAccelerationShapingParts = DEMBUF_PARTS_WHERE(detail::ShapesAcceleration<P>());
constexpr PartMask kAlwaysOnParts = DEMBUF_PARTS_WHERE(detail::AlwaysOn<P>());
constexpr PartMask kPairPickingParts = DEMBUF_PARTS_WHERE(detail::PicksPairConstants<P>());
template <Stage S>
constexpr PartMask kPartsOfStage = DEMBUF_PARTS_WHERE(P::kStage == S);
#undef DEMBUF_PARTS_WHERE

static_assert(std::popcount(kAccelerationShapingParts & kPartsOfStage<Stage::kMotion>) <= 1,
              "at most one part sets a kick's acceleration");
// The law's base comes first (its Lane sets the force the others add to), and the slip's
// reader before any other part that gives torques (MindlinTangential sets the torques).
static_assert(Parts::Bit<HertzNormal>() == 1);
static_assert(static_cast<int>(std::bit_width(kSlipReadingParts & kTurningParts)) <=
              std::countr_zero(kTurningParts & ~kSlipReadingParts));
// A part that advances the history reads it.
static_assert((kHistoryKeepingParts & ~kSlipReadingParts) == 0);

/// The stage's parts that may be off: its kernels have 2^n instances for n of them.
template <Stage S>
constexpr PartMask kOptionalParts = kPartsOfStage<S> & ~kAlwaysOnParts;
template <Stage S>
constexpr std::size_t kInstances = std::size_t{1} << std::popcount(kOptionalParts<S>);

/// The parts of instance k of stage S: the stage's base and the optional parts whose bits k
/// names, the lowest bit of k for the first optional part.
template <Stage S>
constexpr PartMask InstanceParts(std::size_t k) {
  PartMask bits = kPartsOfStage<S> & kAlwaysOnParts;
  for (PartMask rest = kOptionalParts<S>; rest != 0; rest &= rest - 1, k >>= 1)
    if (k & 1) bits |= rest & -rest;
  return bits;
}

/// The instance of stage S for a world's parts (the inverse of InstanceParts).
template <Stage S>
constexpr std::size_t InstanceIndex(PartMask active) {
  std::size_t k = 0, place = 1;
  for (PartMask rest = kOptionalParts<S>; rest != 0; rest &= rest - 1, place <<= 1)
    if (active & rest & -rest) k |= place;
  return k;
}

}  // namespace detail

/// The parts a world calls for: those switched on, and BodyRotation when a part that turns
/// bodies is on.
template <class World>
PartMask ActiveParts(const World& world) {
  const PartMask switched = Parts::Switched(world);
  return switched | ((switched & detail::kTurningParts) ? detail::kFollowingParts : 0);
}

/// A set of parts as a type: what a kernel instance is compiled for. The kernels ask what the
/// parts need (kRotate, kSlip, ...), not which parts they are.
template <PartMask kMask>
struct Effects {
  static constexpr PartMask kParts = kMask;
  template <class P>
  static constexpr bool kHas = (kMask & Parts::Bit<P>()) != 0;
  /// Bodies turn: something gives them torques.
  static constexpr bool kRotate = (kMask & detail::kRotatingParts) != 0;
  /// The contacts' slip velocities and tangential histories are read.
  static constexpr bool kSlip = (kMask & detail::kSlipReadingParts) != 0;
  /// The tangential histories are advanced (and kept in the lists).
  static constexpr bool kHistory = (kMask & detail::kHistoryKeepingParts) != 0;
  /// The relative angular velocities and the pairs' inertia are read.
  static constexpr bool kSpin = (kMask & detail::kSpinReadingParts) != 0;
  /// Each contact reads its kind of pair's constants by the bodies' species (SpeciesTable).
  static constexpr bool kSpecies = (kMask & detail::kPairPickingParts) != 0;
  /// A part sets the kicks' acceleration.
  static constexpr bool kShapedAcceleration = (kMask & detail::kAccelerationShapingParts) != 0;
};

/// The part of E that sets the kicks' acceleration, or void (the plain F/m).
template <class E, class List = Parts>
struct AccelerationPartOf {
  using type = void;
};
template <class E, class P, class... Rest>
struct AccelerationPartOf<E, PartList<P, Rest...>> {
  using type = std::conditional_t<detail::ShapesAcceleration<P>() && E::template kHas<P>, P,
                                  typename AccelerationPartOf<E, PartList<Rest...>>::type>;
};
template <class E>
using AccelerationPart = typename AccelerationPartOf<E>::type;

/// The part of the list that may set the kicks' acceleration, its parameters, and a world's.
using AccelerationShaper = AccelerationPart<Effects<~PartMask{0}>>;
using AccelerationParams = typename AccelerationShaper::Params;
template <class World>
AccelerationParams AccelerationParamsOf(const World& world) {
  return AccelerationShaper::ParamsOf(world);
}

/// The Effects of instance k of stage S.
template <Stage S, std::size_t k>
using StageEffects = Effects<detail::InstanceParts<S>(k)>;

/// The contact parts' arithmetic for one contact, in the list's order: what a vector lane of
/// the force pass runs, and (through Resolve, contact_kernels.h) every other contact too.
template <class E, class P>
DEMBUF_ALWAYS_INLINE void ResolvePart(const ContactLane& c, const ContactConstants& k,
                                      ContactResult& r) {
  if constexpr (P::kStage == Stage::kContact && !detail::PicksPairConstants<P>() &&
                E::template kHas<P>)
    P::Lane(c, k, r);
}
template <class E, class... P>
DEMBUF_ALWAYS_INLINE ContactResult ResolveParts(PartList<P...>, const ContactLane& c,
                                                const ContactConstants& k) {
  ContactResult r;
  (ResolvePart<E, P>(c, k, r), ...);
  return r;
}
template <class E>
DEMBUF_ALWAYS_INLINE ContactResult ResolveContact(const ContactLane& c, const ContactConstants& k) {
  return ResolveParts<E>(Parts{}, c, k);
}

namespace detail {
template <Stage S, class F, std::size_t... k>
void CallInstance(std::size_t index, F& f, std::index_sequence<k...>) {
  assert(index < sizeof...(k));
  (void)((index == k ? (f(StageEffects<S, k>{}), true) : false) || ...);
}
template <Stage S, class Make, std::size_t... k>
constexpr auto MakeInstanceTable(Make& make, std::index_sequence<k...>) {
  return std::array{make(StageEffects<S, k>{})...};
}
}  // namespace detail

/// Calls f(Effects<...>{}) with the instance of stage S for the parts `active`.
template <Stage S, class F>
void WithEffects(PartMask active, F&& f) {
  detail::CallInstance<S>(detail::InstanceIndex<S>(active), f,
                          std::make_index_sequence<detail::kInstances<S>>{});
}

/// A table of one entry per instance of stage S, make(Effects<...>{}) each, in InstanceIndex's
/// order (the function pointers of a kernel's instances).
template <Stage S, class Make>
constexpr auto InstanceTable(Make make) {
  return detail::MakeInstanceTable<S>(make, std::make_index_sequence<detail::kInstances<S>>{});
}

}  // namespace dembuf::dem
