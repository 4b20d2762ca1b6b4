#include "dembuf/engine/bed_io.h"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <unordered_map>
#include <vector>

#include "dembuf/engine/errors.h"

namespace dembuf {

namespace {

// Overlaps much above 1% of a radius store so much elastic energy that relaxing them throws
// beads out of the cylinder (5% did, in the hard-case test); such a bed is refused instead.
constexpr double kMaxImportOverlap = 0.01;

// Finds the largest overlap between beads (relative to the smaller radius) with a hash grid of
// cells one largest diameter wide, and refuses the bed if it passes kMaxImportOverlap.
void CheckImportOverlaps(const ParticleState& beads, const std::vector<long>& bead_line,
                         const std::string& path) {
  double r_max = 0.0;
  for (double r : beads.radius) r_max = std::max(r_max, r);
  const double cell = 2.0 * r_max;
  auto key = [&](long ix, long iy, long iz) {
    return (ix * 73856093L) ^ (iy * 19349663L) ^ (iz * 83492791L);
  };
  auto index = [&](double v) { return static_cast<long>(std::floor(v / cell)); };
  std::unordered_map<long, std::vector<std::size_t>> grid;
  for (std::size_t i = 0; i < beads.size(); ++i) {
    const Vec3& x = beads.position[i];
    grid[key(index(x.x()), index(x.y()), index(x.z()))].push_back(i);
  }
  double worst = 0.0;
  std::size_t worst_i = 0, worst_j = 0;
  for (std::size_t i = 0; i < beads.size(); ++i) {
    const Vec3& x = beads.position[i];
    const long cx = index(x.x()), cy = index(x.y()), cz = index(x.z());
    for (long dx = -1; dx <= 1; ++dx)
      for (long dy = -1; dy <= 1; ++dy)
        for (long dz = -1; dz <= 1; ++dz) {
          auto it = grid.find(key(cx + dx, cy + dy, cz + dz));
          if (it == grid.end()) continue;
          for (std::size_t j : it->second) {
            if (j <= i) continue;
            const double reach = beads.radius[i] + beads.radius[j];
            const double overlap = reach - (beads.position[j] - x).norm();
            const double ratio = overlap / std::min(beads.radius[i], beads.radius[j]);
            if (ratio > worst) {
              worst = ratio;
              worst_i = i;
              worst_j = j;
            }
          }
        }
  }
  if (worst > kMaxImportOverlap) {
    char percent[32];
    std::snprintf(percent, sizeof percent, "%.3g%%", 100 * worst);
    throw SceneError("bed.import",
                     path + ": the beads of lines " + std::to_string(bead_line[worst_i]) + " and " +
                         std::to_string(bead_line[worst_j]) + " overlap by " + percent +
                         " of the smaller radius; an imported bed may overlap by at most 1% "
                         "(relaxing more would throw beads out): separate them or shrink "
                         "the radii");
  }
}

}  // namespace

ParticleState ImportTextBed(const std::string& path, const Scene& scene) {
  std::ifstream in(path);
  if (!in) throw SceneError("bed.import", "cannot open \"" + path + "\"");
  ParticleState beads;
  std::vector<long> bead_line;  // the file line of each bead, for messages
  std::string line;
  long line_no = 0;
  auto fail = [&](const std::string& why) {
    throw SceneError("bed.import", path + ":" + std::to_string(line_no) + ": " + why);
  };
  while (std::getline(in, line)) {
    ++line_no;
    if (auto hash = line.find('#'); hash != std::string::npos) line.erase(hash);
    std::istringstream fields(line);
    double x, y, z, r;
    if (!(fields >> x)) continue;  // blank or comment line
    if (!(fields >> y >> z >> r)) fail("expected four numbers: x y z radius");
    std::string extra;
    if (fields >> extra) fail("unexpected text \"" + extra + "\" after the radius");
    if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z) || !std::isfinite(r))
      fail("non-finite value");
    if (r <= 0.0) fail("radius " + std::to_string(r) + " must be > 0");
    if (std::hypot(x, y) + r > scene.cylinder.radius_m * (1.0 + 1e-9))
      fail("bead reaches outside the cylinder (radius " + std::to_string(scene.cylinder.radius_m) +
           " m)");
    if (z - r < -1e-9 * r) fail("bead reaches below the plate (z - radius < 0)");
    beads.Add(Vec3(x, y, z), r, scene.material.density_kg_m3);
    bead_line.push_back(line_no);
  }
  if (beads.size() == 0) throw SceneError("bed.import", "\"" + path + "\" holds no beads");
  CheckImportOverlaps(beads, bead_line, path);
  return beads;
}

double BedSurfaceHeight(const ParticleState& beads) {
  double top = 0.0;
  for (std::size_t i = 0; i < beads.size(); ++i)
    top = std::max(top, beads.position[i].z() + beads.radius[i]);
  return top;
}

}  // namespace dembuf
