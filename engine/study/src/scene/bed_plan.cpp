#include "dembuf/study/scene/bed_plan.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace dembuf {

SourcePlan PlanSourceBed(const Scene& scene) {
  SourcePlan plan;
  // Every H up to source_thickness_m - d_max is cut from the same source; a thicker bed gets
  // a source of its own, two bead diameters thicker than itself.
  const double d_min = scene.beads.diameter_min_m, d_max = scene.beads.diameter_max_m;
  plan.thickness_m = scene.bed.thickness_m + d_max <= scene.bed.source_thickness_m
                         ? scene.bed.source_thickness_m
                         : scene.bed.thickness_m + 2.0 * d_max;
  // Enough beads to settle into a bed of at least that thickness at a packing no denser than
  // 0.66. Mean volume of a sphere with d uniform in [d_min, d_max]: pi/6 <d^3>.
  const double d_mean = 0.5 * (d_min + d_max);
  const double mean_d3 =
      (std::pow(d_max, 4) - std::pow(d_min, 4)) / (4.0 * std::max(d_max - d_min, 1e-300));
  plan.mean_bead_volume_m3 =
      std::numbers::pi / 6.0 * (d_max > d_min ? mean_d3 : d_mean * d_mean * d_mean);
  const double area = std::numbers::pi * scene.cylinder.radius_m * scene.cylinder.radius_m;
  plan.beads = std::ceil(0.66 * area * (plan.thickness_m + d_max) / plan.mean_bead_volume_m3);
  plan.column_top_m = plan.beads * plan.mean_bead_volume_m3 / (0.30 * area) + d_max;
  return plan;
}

double SoftPourOverlap(const Scene& scene, double softening) {
  const double r = 0.5 * scene.beads.diameter_min_m;
  const double mass = scene.material.density_kg_m3 * 4.0 / 3.0 * std::numbers::pi * r * r * r;
  const double v2 = 2.0 * scene.gravity_m_s2 * scene.cylinder.height_m;
  const double nu = scene.material.poisson_ratio;
  const double e_bead = scene.material.youngs_modulus_Pa / softening / (1.0 - nu * nu);
  const double e_wall = scene.walls.material_from_beads
                            ? e_bead
                            : scene.walls.youngs_modulus_Pa / softening /
                                  (1.0 - scene.walls.poisson_ratio * scene.walls.poisson_ratio);
  auto largest_overlap = [&](double m_star, double e_star, double r_star) {
    return std::pow(15.0 * m_star * v2 / (16.0 * e_star * std::sqrt(r_star)), 0.4);
  };
  return std::max(largest_overlap(0.5 * mass, 0.5 * e_bead, 0.5 * r),
                  largest_overlap(mass, 1.0 / (1.0 / e_bead + 1.0 / e_wall), r)) /
         r;
}

double SoftSettlingFactor(const Scene& scene) {
  if (scene.bed.thickness_m <= 0.0 || !scene.bed.import.empty()) return 1.0;
  if (scene.bed.soft_settling != 0.0) return scene.bed.soft_settling;
  // Hertz's overlap goes as E^(-2/5), so as softening^(2/5).
  const double largest = std::pow(kMaxSoftOverlap / SoftPourOverlap(scene, 1.0), 2.5);
  const double softening = std::floor(std::min(kAutoSoftening, largest));
  return softening >= 2.0 ? softening : 1.0;
}

bool NeedsFrictionStage(const Scene& scene) {
  return scene.material.friction_bead_bead != scene.bed.prep_friction;
}

}  // namespace dembuf
