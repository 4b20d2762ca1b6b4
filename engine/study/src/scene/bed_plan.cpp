#include "dembuf/study/scene/bed_plan.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "dembuf/study/scene/species.h"

namespace dembuf {

namespace {

// A layer of `fraction`s from `bottom` with enough beads to settle to at least `top` at a
// packing no denser than 0.66, in a loose column of solid fraction 0.30 above `bottom`.
LayerPlan PlanLayer(const Scene& scene, const std::array<double, kMaxSpecies>& fraction,
                    double bottom, double top) {
  LayerPlan layer;
  layer.bottom_m = bottom;
  layer.top_m = top;
  layer.fraction = fraction;
  // The mean bead volume of the mixture: species k is a fraction f_k / v_k of the beads, for
  // its mean volume v_k. One species alone: its own (the arithmetic the bed of one species has
  // always had).
  int present = 0, only = 0;
  double beads_per_volume = 0.0, d_max = 0.0;
  for (int k = 0; k < kMaxSpecies; ++k) {
    if (fraction[k] <= 0.0) continue;
    const SpeciesMaterial m = SpeciesOf(scene, k);
    ++present;
    only = k;
    beads_per_volume += fraction[k] / m.MeanVolume();
    d_max = std::max(d_max, m.diameter_max_m);
  }
  layer.mean_bead_volume_m3 =
      present == 1 ? SpeciesOf(scene, only).MeanVolume() : 1.0 / beads_per_volume;
  layer.largest_diameter_m = d_max;
  const double area = std::numbers::pi * scene.cylinder.radius_m * scene.cylinder.radius_m;
  layer.beads = std::ceil(0.66 * area * (top - bottom + d_max) / layer.mean_bead_volume_m3);
  layer.column_top_m = bottom + layer.beads * layer.mean_bead_volume_m3 / (0.30 * area) + d_max;
  return layer;
}

}  // namespace

SourcePlan PlanSourceBed(const Scene& scene) {
  SourcePlan plan;
  // Every H up to source_thickness_m - d_max is cut from the same source; a thicker bed gets
  // a source of its own, two bead diameters thicker than itself.
  const double d_max = LargestDiameter(scene);
  plan.thickness_m = scene.bed.thickness_m + d_max <= scene.bed.source_thickness_m
                         ? scene.bed.source_thickness_m
                         : scene.bed.thickness_m + 2.0 * d_max;
  // A top layer of several species is poured to H instead: heavy beads sink through light ones
  // as a bed settles, so a cut from a deeper source would keep more of them than asked.
  const int layers = LayerCount(scene);
  if (MixesSpecies(scene, layers - 1)) plan.thickness_m = scene.bed.thickness_m;
  for (int layer = 0; layer < layers; ++layer) {
    std::array<double, kMaxSpecies> fraction{};
    for (int k = 0; k < kMaxSpecies; ++k) fraction[k] = LayerFraction(scene, layer, k);
    const double bottom = LayerBottom(scene, layer);
    const double top =
        layer + 1 < layers ? bottom + scene.layers[layer].thickness_m : plan.thickness_m;
    plan.layers.push_back(PlanLayer(scene, fraction, bottom, top));
    plan.beads += plan.layers.back().beads;
    plan.column_top_m = std::max(plan.column_top_m, plan.layers.back().column_top_m);
  }
  plan.mean_bead_volume_m3 = plan.layers.back().mean_bead_volume_m3;
  return plan;
}

double SoftPourOverlap(const Scene& scene, double softening) {
  const double v2 = 2.0 * scene.gravity_m_s2 * scene.cylinder.height_m;
  auto largest_overlap = [&](double m_star, double e_star, double r_star) {
    return std::pow(15.0 * m_star * v2 / (16.0 * e_star * std::sqrt(r_star)), 0.4);
  };
  // The smallest beads of each species in the bed, on one of their own or the plate.
  double largest = 0.0;
  for (int k = 0; k < SpeciesCount(scene); ++k) {
    if (!HasBeadsOf(scene, k)) continue;
    const SpeciesMaterial m = SpeciesOf(scene, k);
    const double r = 0.5 * m.diameter_min_m;
    const double mass = m.density_kg_m3 * 4.0 / 3.0 * std::numbers::pi * r * r * r;
    const double nu = m.poisson_ratio;
    const double e_bead = m.youngs_modulus_Pa / softening / (1.0 - nu * nu);
    const double e_wall =
        scene.walls.material_from_beads
            ? scene.material.youngs_modulus_Pa / softening /
                  (1.0 - scene.material.poisson_ratio * scene.material.poisson_ratio)
            : scene.walls.youngs_modulus_Pa / softening /
                  (1.0 - scene.walls.poisson_ratio * scene.walls.poisson_ratio);
    const double overlap = std::max(largest_overlap(0.5 * mass, 0.5 * e_bead, 0.5 * r),
                                    largest_overlap(mass, 1.0 / (1.0 / e_bead + 1.0 / e_wall), r)) /
                           r;
    largest = std::max(largest, overlap);
  }
  return largest;
}

double SoftSettlingFactor(const Scene& scene) {
  if (scene.bed.thickness_m <= 0.0 || !scene.bed.import.empty()) return 1.0;
  if (scene.bed.soft_settling != 0.0) return scene.bed.soft_settling;
  // Hertz's overlap goes as E^(-2/5), so as softening^(2/5).
  const double largest = std::pow(kMaxSoftOverlap / SoftPourOverlap(scene, 1.0), 2.5);
  const double softening = std::floor(std::min(kAutoSoftening, largest));
  return softening >= 2.0 ? softening : 1.0;
}

double CutRelaxationAlpha(const Scene& scene) {
  if (scene.bed.cut_alpha > 0.0) return scene.bed.cut_alpha;
  if (scene.bed.quench_cut_relaxation) return scene.time.alpha;
  return std::max(scene.time.alpha,
                  std::min(kLongestCheckedCutAlpha, kAutoCutStepMultiple * scene.time.alpha));
}

bool NeedsFrictionStage(const Scene& scene) {
  for (int a = 0; a < SpeciesCount(scene); ++a)
    for (int b = a; b < SpeciesCount(scene); ++b)
      if (HasBeadsOf(scene, a) && HasBeadsOf(scene, b) &&
          PairFriction(scene, a, b) != scene.bed.prep_friction)
        return true;
  return false;
}

}  // namespace dembuf
