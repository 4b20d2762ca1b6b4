#include "dembuf/engine/bed_io.h"

#include <cmath>
#include <fstream>
#include <sstream>

#include "dembuf/engine/errors.h"

namespace dembuf {

ParticleState ImportTextBed(const std::string& path, const Scene& scene) {
  std::ifstream in(path);
  if (!in) throw SceneError("bed.import", "cannot open \"" + path + "\"");
  ParticleState beads;
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
  }
  if (beads.size() == 0) throw SceneError("bed.import", "\"" + path + "\" holds no beads");
  return beads;
}

double BedSurfaceHeight(const ParticleState& beads) {
  double top = 0.0;
  for (std::size_t i = 0; i < beads.size(); ++i)
    top = std::max(top, beads.position[i].z() + beads.radius[i]);
  return top;
}

}  // namespace dembuf
