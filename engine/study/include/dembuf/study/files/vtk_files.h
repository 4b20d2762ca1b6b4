// Beds, snapshots and animation frames as VTK XML files, which ParaView, VisIt and VTK read:
//   beads (.vtp)     every bead a vertex at its centre, with radius_m, velocity_m_s, id,
//                    species (1, 2, 3 as the scene numbers them: ParaView colours by it) and
//                    force_N (its contact force); the projectile, when there is one, is the
//                    last point, with id -1 and species 0
//   contacts (.vtp)  the bead-bead and projectile-bead contacts, lines between the centres,
//                    with normal_force_N
//   a .pvd           a collection of them with their times, which ParaView plays in order
// Arrays are written in binary (base64, VTK's inline "binary" format), positions and vectors
// in double precision, so a file of beads is about 130 bytes a bead.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "dembuf/core/particles.h"
#include "dembuf/study/impact/impact.h"

namespace dembuf::report {

/// The beads of a snapshot or frame (and its projectile) as a .vtp file.
std::string BeadsVtp(const ImpactSnapshot& snap);

/// The contacts of a snapshot as a .vtp file: the same points as BeadsVtp, and a line per
/// contact of two bodies (contacts with the plate or the wall have no second centre).
std::string ContactsVtp(const ImpactSnapshot& snap);

/// The container as a .vtp file: the bottom plate (a polygon at z = 0) and the side wall
/// (quads up to its rim), with a cell array `part` (0 plate, 1 wall). Written once a run, as
/// container.vtp, and a part of snapshots.pvd and frames.pvd.
std::string ContainerVtp(double radius_m, double height_m);

/// A bed's beads as a .vtp file (ids in the bed's order, no forces).
std::string BedVtp(const dem::ParticleState& beads);

/// A .pvd collection: each entry a time, a part number and a file path relative to the .pvd.
/// Entries are written in time order.
struct PvdEntry {
  double t_s;
  int part;
  std::string file;
};
std::string Pvd(std::vector<PvdEntry> entries);

/// Bytes per bead of BeadsVtp, for cost estimates (each bead's arrays, base64).
inline constexpr double kVtpBytesPerBead = 130;

}  // namespace dembuf::report
