// Animation frames as LAMMPS dump files (output.frame_format = "lammps" or "both"), for OVITO
// and LAMMPS users: frames/LABEL.dump, one frame each, a file sequence OVITO loads as one
// animation (frames/*.dump) and the bed import reads as a bed (its beads, and the projectile).
#pragma once

#include <cstdint>
#include <string>

#include "dembuf/study/impact/impact.h"

namespace dembuf::report {

/// The frame as a LAMMPS text dump ("custom" style): ITEM: TIME (the simulated time, s), ITEM:
/// TIMESTEP (the frame's number), the box around the cylinder, then a line per atom, `id type
/// x y z radius vx vy vz fx fy fz` in SI units. Beads are atoms 1..N in the order of their ids
/// in the bed, type k for species k; the projectile, if any, is atom N+1 of type 4 (one past
/// the last species).
std::string LammpsDumpFrame(const ImpactSnapshot& frame, std::int64_t number,
                            double cylinder_radius_m, double cylinder_height_m);

/// The atom type of the projectile in LammpsDumpFrame.
inline constexpr int kDumpProjectileType = 4;

/// Bytes per atom of LammpsDumpFrame, for cost estimates (twelve numbers of about 13 bytes).
inline constexpr double kDumpBytesPerBead = 160;

}  // namespace dembuf::report
