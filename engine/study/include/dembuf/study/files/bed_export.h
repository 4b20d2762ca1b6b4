// A prepared bed written for other programs (`dembuf bed export`), so that a bed can be looked
// at in ParaView or cross-checked in LAMMPS or Yade:
//   text    one bead per line, "x y z radius" in metres: the format bed.import reads back
//   lammps  a LAMMPS data file (atom_style sphere: id type diameter density x y z, then the
//           velocities), for read_data; the box is the cylinder's, plus 5 mm around
//   vtp     VTK XML beads (vtk_files.h)
// Every number is written to 17 significant digits, so a text bed reads back bit for bit.
#pragma once

#include <optional>
#include <span>
#include <string>
#include <string_view>

#include "dembuf/core/particles.h"
#include "dembuf/study/scene/scene.h"

namespace dembuf {

enum class BedFormat { kText, kLammps, kVtp };

/// The formats a bed is exported in, by name: the one list the CLI's choices, its help and
/// its completion are made of.
struct BedFormatName {
  BedFormat format;
  std::string_view name;  ///< "text", "lammps", "vtp"
  std::string_view help;
};
std::span<const BedFormatName> BedFormatNames();

/// The format of a name of BedFormatNames; nullopt for another name.
std::optional<BedFormat> ParseBedFormat(std::string_view name);

/// The bed in that format. `scene` gives the container (the LAMMPS box) and the species' names
/// in the file's header; a bead's species k is its atom type k (a LAMMPS file's type, a text
/// file's type column when there are several); `projectile`, when given, is added to a LAMMPS
/// file as the type after the species'.
std::string ExportBed(const dem::ParticleState& beads, const Scene& scene, BedFormat format,
                      const std::string& title,
                      const std::optional<dem::RigidSphere>& projectile = std::nullopt);

}  // namespace dembuf
