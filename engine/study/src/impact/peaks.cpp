#include "dembuf/study/impact/peaks.h"

#include <algorithm>
#include <cmath>

namespace dembuf {

PeakAnalysis AnalyzePeaks(const ImpactSeries& s, const PeakContext& context,
                          const PeakOptions& options) {
  const double rest_force_N = context.rest_force_N;
  PeakAnalysis out;
  const std::size_t n = s.t_s.size();
  if (n < 3) return out;

  // 1. Excess over the resting load, smoothed by a centred moving average of about
  //    `smoothing_s` (the half width in samples follows the mean sampling interval).
  std::vector<double> excess(n), smooth(n);
  for (std::size_t k = 0; k < n; ++k) excess[k] = s.plate_force_N[k] - rest_force_N;
  const double spacing = (s.t_s.back() - s.t_s.front()) / static_cast<double>(n - 1);
  const auto half = static_cast<std::size_t>(
      std::max(0.0, std::round(0.5 * options.smoothing_s / std::max(spacing, 1e-300))));
  std::vector<double> prefix(n + 1, 0.0);
  for (std::size_t k = 0; k < n; ++k) prefix[k + 1] = prefix[k] + excess[k];
  for (std::size_t k = 0; k < n; ++k) {
    const std::size_t a = k > half ? k - half : 0, b = std::min(n - 1, k + half);
    smooth[k] = (prefix[b + 1] - prefix[a]) / static_cast<double>(b + 1 - a);
  }
  const double top = *std::max_element(smooth.begin(), smooth.end());
  if (!(top > 0.0)) return out;

  // 2. Local maxima (plateaus count once, at their first sample) and their prominence.
  std::vector<std::size_t> maxima;
  for (std::size_t k = 1; k + 1 < n; ++k) {
    if (!(smooth[k] > smooth[k - 1])) continue;
    std::size_t e = k;
    while (e + 1 < n && smooth[e + 1] == smooth[k]) ++e;
    if (e + 1 < n && smooth[e + 1] < smooth[k]) maxima.push_back(k);
  }
  for (std::size_t m : maxima) {
    double left_min = smooth[m], right_min = smooth[m];
    for (std::size_t k = m; k-- > 0;) {
      if (smooth[k] > smooth[m]) break;
      left_min = std::min(left_min, smooth[k]);
    }
    for (std::size_t k = m + 1; k < n; ++k) {
      if (smooth[k] > smooth[m]) break;
      right_min = std::min(right_min, smooth[k]);
    }
    const double prominence = smooth[m] - std::max(left_min, right_min);
    if (prominence < options.min_prominence * top) continue;

    // 3. The raw maximum near the smoothed peak.
    const std::size_t a = m > half ? m - half : 0, b = std::min(n - 1, m + half);
    std::size_t best = a;
    for (std::size_t k = a; k <= b; ++k)
      if (excess[k] > excess[best]) best = k;
    ForcePeak peak;
    peak.force_N = s.plate_force_N[best];
    peak.time_s = s.t_s[best];
    peak.projectile_z_m = s.projectile_z_m.empty() ? 0.0 : s.projectile_z_m[best];
    // 4. Wave or push, by the layer left beneath the projectile.
    const double thin_layer = std::max(options.push_depth_fraction * context.bed_thickness_m,
                                       options.push_layer_diameters * context.bead_diameter_m);
    peak.is_push = s.projectile_z_m.empty() ||
                   s.projectile_z_m[best] - context.projectile_radius_m < thin_layer;
    out.peaks.push_back(peak);
  }

  for (const ForcePeak& p : out.peaks) {
    bool& has = p.is_push ? out.has_pa : out.has_pb;
    ForcePeak& slot = p.is_push ? out.pa : out.pb;
    if (!has || p.force_N > slot.force_N) {
      slot = p;
      has = true;
    }
  }
  // 5. P, the travel and time between the peaks, and the load duration.
  if (out.has_pa || out.has_pb) {
    const ForcePeak& p =
        !out.has_pb || (out.has_pa && out.pa.force_N >= out.pb.force_N) ? out.pa : out.pb;
    out.p_N = p.force_N;
    out.p_time_s = p.time_s;
  }
  if (out.has_pa && out.has_pb) {
    out.ds_m = std::abs(out.pb.projectile_z_m - out.pa.projectile_z_m);
    out.dt_peaks_s = out.pa.time_s - out.pb.time_s;
  }
  const double level = options.duration_fraction * top;
  std::size_t first = n, last = 0;
  for (std::size_t k = 0; k < n; ++k)
    if (smooth[k] > level) {
      first = std::min(first, k);
      last = k;
    }
  if (first < n) out.load_duration_s = s.t_s[last] - s.t_s[first];
  return out;
}

}  // namespace dembuf
