// The peaks of the bottom force (docs/model.md sections 6 and 7, E2).
//
// The paper's bottom force has up to two kinds of peak: Pb, the stress wave sent through the
// bed when the projectile strikes its surface, and Pa, the projectile pressing on the plate
// through the thin layer left beneath it (or hitting the bare plate). We tell them apart by
// where the projectile is at the peak, not by their order:
//
//  1. Work on the excess over the resting load, F(t) - F_rest, smoothed by a centred moving
//     average of width `smoothing_s` (DEM forces are noisy at the scale of single contacts).
//  2. Peaks are local maxima of the smoothed signal with a prominence of at least
//     `min_prominence` times its maximum (prominence: height above the higher of the two
//     minima that separate it from higher ground on each side).
//  3. Each peak's value and time are those of the raw signal's maximum within one smoothing
//     width of it.
//  4. A peak while the layer left beneath the projectile's lowest point is still thick is a
//     wave peak (Pb): the bed is being struck. A peak with less than max(H/2, 2 d) left beneath
//     it (H the bed thickness, d the mean bead diameter) is a push peak (Pa): the projectile
//     presses on the plate through a thin layer (the paper's dS = 0.91 H - 0.32 cm says it has
//     crossed most of the bed by then). In a bed at most two beads deep the wave and the push
//     are one event, so all its peaks are Pa. Pb is the largest
//     wave peak, Pa the largest push peak; either may be absent. Repeated plate hits of a thin
//     bed give several push peaks; Pa is the largest. Without beads every peak is Pa.
//  5. P = max(Pa, Pb). Load duration: from the first to the last time the smoothed excess
//     exceeds `duration_fraction` (5%) of its maximum.
#pragma once

#include <vector>

namespace dembuf {

struct PeakOptions {
  double smoothing_s = 5e-5;
  double min_prominence = 0.10;
  double push_depth_fraction = 0.5;   ///< of H
  double push_layer_diameters = 2.0;  ///< of d
  double duration_fraction = 0.05;
};

struct ForcePeak {
  double force_N = 0.0;  ///< total plate force at the peak (resting load included)
  double time_s = 0.0;
  double projectile_z_m = 0.0;
  bool is_push = false;  ///< Pa kind (projectile slowed); otherwise Pb kind
};

struct PeakAnalysis {
  std::vector<ForcePeak> peaks;  ///< every significant peak, in time order
  bool has_pa = false, has_pb = false;
  ForcePeak pa, pb;
  double p_N = 0.0;  ///< max(Pa, Pb)
  double p_time_s = 0.0;
  double load_duration_s = 0.0;
  double ds_m = 0.0;        ///< projectile travel from Pb to Pa (both present), else 0
  double dt_peaks_s = 0.0;  ///< t(Pa) - t(Pb) (both present), else 0
};

/// A series sampled at increasing times (every step, or every output interval).
struct ImpactSeries {
  std::vector<double> t_s;
  std::vector<double> plate_force_N;
  std::vector<double> projectile_z_m;  ///< centre height (empty: no projectile)
};

/// What the classification needs to know of the scene.
struct PeakContext {
  double rest_force_N = 0.0;     ///< plate load of the bed at rest before the impact
  double bed_thickness_m = 0.0;  ///< H
  double projectile_radius_m = 0.0;
  double bead_diameter_m = 0.0;  ///< mean bead diameter d
};

/// Finds and classifies the peaks.
PeakAnalysis AnalyzePeaks(const ImpactSeries& series, const PeakContext& context,
                          const PeakOptions& options = {});

}  // namespace dembuf
