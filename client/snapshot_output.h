// Files of a contact-network snapshot, in DIR/snapshots/<label>/:
//   network.vtk       beads (points, radius) and bead/projectile contacts (lines, forces), for
//                     ParaView (legacy VTK polydata)
//   contacts.csv      every contact: bodies, contact point, force vector, normal force
//   plate_radial.csv  plate load by ring of width one bead diameter: force and pressure
//   plate_map.csv     plate load on a square grid of 1 cm cells
//   force_pdf.csv     probability density of bead-bead normal forces over their mean
#pragma once

#include <filesystem>

#include "dembuf/study/impact.h"

namespace dembuf::cli {

/// Writes the snapshot's files; returns the folder.
std::filesystem::path WriteSnapshot(const ImpactSnapshot& snap, const std::filesystem::path& dir,
                                    double cylinder_radius_m, double bead_diameter_m);

}  // namespace dembuf::cli
