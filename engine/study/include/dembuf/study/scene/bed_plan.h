// What a scene's bed will be, computed from the scene alone (nothing prepared, nothing
// allocated): the source bed's beads and column, the soft settling factor, the stages it needs.
// Scene validation checks these before a bed is prepared.
#pragma once

#include <array>
#include <vector>

#include "dembuf/study/scene/scene.h"

namespace dembuf {

/// The most beads a simulation may hold: bead ids are 32-bit, with two values reserved.
inline constexpr double kMaxBeads = 1e9;

/// How a scene's source bed is made: its thickness, the beads inserted (exactly as many as its
/// preparation inserts) and the height of the loose column they start in. Computed without
/// allocating anything; `beads` is a double, so that an absurd scene
/// can be refused before any count is taken.
/// One layer of it (LayerSpec), poured in turn from the plate up: the beads inserted above the
/// layers below, in a loose column from `bottom_m` to `column_top_m`, settled, and (all but the
/// last) cut at `top_m`. The last layer's top is the source's thickness.
struct LayerPlan {
  double bottom_m = 0.0;
  double top_m = 0.0;
  double beads = 0.0;
  double mean_bead_volume_m3 = 0.0;
  double column_top_m = 0.0;
  double largest_diameter_m = 0.0;
  /// The volume fraction of each species (0-based) in the layer.
  std::array<double, kMaxSpecies> fraction{};
};
struct SourcePlan {
  double thickness_m = 0.0;
  double beads = 0.0;                ///< all layers'
  double mean_bead_volume_m3 = 0.0;  ///< the top layer's
  double column_top_m = 0.0;         ///< the highest of the layers' columns
  std::vector<LayerPlan> layers;
};
SourcePlan PlanSourceBed(const Scene& scene);

/// Soft settling: the source bed's pour may overlap by at most this share of the smallest
/// bead's radius, and the automatic factor (bed.soft_settling = 0) is at most kAutoSoftening.
inline constexpr double kMaxSoftOverlap = 0.1;
inline constexpr double kAutoSoftening = 100.0;
/// The largest overlap of the source bed's pour, as a share of the smallest bead's radius,
/// with Young's modulus (beads and walls) divided by `softening`: Hertz's, for the smallest
/// beads falling from the top of the wall onto a bead or the plate.
double SoftPourOverlap(const Scene& scene, double softening);
/// The factor the source bed settles with: bed.soft_settling, or for 0 (automatic) the
/// largest whole number up to kAutoSoftening whose pour stays within kMaxSoftOverlap; 1 (the
/// true stiffness) where that is below 2, and for a scene without a bed or with an imported one.
double SoftSettlingFactor(const Scene& scene);
/// bed.cut_alpha = 0 (automatic) relaxes the cut bed with this many times time.alpha's step...
inline constexpr double kAutoCutStepMultiple = 4.0;
/// ...but at most with this factor: the longest cut step the tests and the E2 sweeps check.
inline constexpr double kLongestCheckedCutAlpha = 0.8;
/// The time-step factor the bed cut to H relaxes with: bed.cut_alpha, or for 0 (automatic)
/// kAutoCutStepMultiple times time.alpha, at most kLongestCheckedCutAlpha and at least
/// time.alpha; time.alpha itself with bed.quench_cut_relaxation (the draft's kinetic damping
/// of the whole bed), whose rest check let beds relaxed at longer steps pass out of balance
/// (a longer step set with it is refused).
double CutRelaxationAlpha(const Scene& scene);

/// Whether the bed needs the friction stage: mu_pp differs from bed.prep_friction.
bool NeedsFrictionStage(const Scene& scene);

}  // namespace dembuf
