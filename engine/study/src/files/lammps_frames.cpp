#include "dembuf/study/files/lammps_frames.h"

#include <cstdio>
#include <string>

namespace dembuf::report {

std::string LammpsDumpFrame(const ImpactSnapshot& frame, std::int64_t number,
                            double cylinder_radius_m, double cylinder_height_m) {
  const std::size_t beads = frame.positions.size();
  const std::size_t atoms = beads + (frame.projectile ? 1 : 0);
  std::string out;
  out.reserve(200 + atoms * 170);
  char line[512];
  std::snprintf(line, sizeof line,
                "ITEM: TIME\n%.17g\nITEM: TIMESTEP\n%lld\nITEM: NUMBER OF ATOMS\n%zu\n"
                "ITEM: BOX BOUNDS ff ff ff\n%.17g %.17g\n%.17g %.17g\n%.17g %.17g\n"
                "ITEM: ATOMS id type x y z radius vx vy vz fx fy fz\n",
                frame.t_s, static_cast<long long>(number), atoms, -cylinder_radius_m,
                cylinder_radius_m, -cylinder_radius_m, cylinder_radius_m, 0.0, cylinder_height_m);
  out += line;
  // Each atom's numbers to 9 digits: a frame is for looking at (the bed export keeps 17).
  auto atom = [&](long long id, int type, const dem::Vec3& x, double r, const dem::Vec3& v,
                  const dem::Vec3& f) {
    std::snprintf(line, sizeof line, "%lld %d %.9g %.9g %.9g %.9g %.9g %.9g %.9g %.9g %.9g %.9g\n",
                  id, type, x.x(), x.y(), x.z(), r, v.x(), v.y(), v.z(), f.x(), f.y(), f.z());
    out += line;
  };
  const dem::Vec3 zero = dem::Vec3::Zero();
  for (std::size_t i = 0; i < beads; ++i)
    atom(static_cast<long long>(i < frame.ids.size() ? frame.ids[i] : i) + 1,
         1 + (i < frame.species.size() ? frame.species[i] : 0), frame.positions[i], frame.radii[i],
         i < frame.velocities.size() ? frame.velocities[i] : zero,
         i < frame.forces.size() ? frame.forces[i] : zero);
  if (frame.projectile)
    atom(static_cast<long long>(beads) + 1, kDumpProjectileType, frame.projectile->position,
         frame.projectile->radius, frame.projectile->velocity, zero);
  return out;
}

}  // namespace dembuf::report
