// Beds as files, so that packings made by other codes can be used: dembuf's plain text (one
// bead per line: x y z radius, in bed.import_units, metres by default; '#' starts a comment; an
// optional first line naming the columns and their units), LAMMPS data and dump files
// (bed_formats.h).
//
// A bed file is checked as hostile input: its size and line lengths are bounded, every bead
// must lie inside the container, and overlaps are measured. A bed at rest has small overlaps
// at its contacts (LAMMPS leaves 0.3 um between 4 mm glass beads and on the plate, 0.015% of
// a radius): up to kMaxRestingOverlap they are accepted as the resting contacts they are and
// reported. Larger ones store enough elastic energy to throw beads out when relaxed (5% of a
// radius did, in a hard-case test): they are refused naming the worst bead, or, with
// bed.import_overlaps = "relax", separated by moving the beads apart before the bed relaxes.
#pragma once

#include <cstddef>
#include <istream>
#include <string>
#include <vector>

#include "dembuf/core/particles.h"
#include "dembuf/study/bed/bed_formats.h"
#include "dembuf/study/scene/scene.h"

namespace dembuf {

/// The largest overlap accepted as a resting contact, as a fraction of the (smaller) radius.
inline constexpr double kMaxRestingOverlap = 0.01;

/// The overlaps of one kind of contact, as fractions of the (smaller) radius.
struct OverlapStats {
  std::size_t contacts = 0;  ///< touching bead pairs, or beads touching the plate or the wall
  double max_ratio = 0.0;
  double mean_ratio = 0.0;
};

/// A bed read from a text file, and what its contacts look like.
struct ImportedBed {
  BedFileFormat format = BedFileFormat::kText;
  dem::ParticleState beads;  ///< with the scene's density (a LAMMPS file's is not read)
  std::vector<long> lines;   ///< each bead's line in the file
  OverlapStats pairs, plate, wall;
  std::size_t moved = 0;          ///< beads moved apart (bed.import_overlaps = "relax")
  double max_move_m = 0.0;        ///< the farthest one moved
  double max_ratio_before = 0.0;  ///< the largest overlap before they were moved
  /// Where the file disagrees with the scene (its densities, its beads' sizes), as "field:
  /// what" sentences: the run goes on with the scene's density and the file's sizes.
  std::vector<std::string> warnings;
  /// How many species its atom types became (bed.import_types; 1: all species 1).
  int species = 1;

  /// One paragraph for people: the beads, their resting contacts, what was separated.
  std::string Describe() const;
};

/// The smallest bead radius an imported bed may hold: 1 um. Finer powders are held together by
/// adhesion and moved by the air, which the model leaves out; and the neighbour grid, in cells
/// of a bead's size across the whole container, would take more memory than a machine has.
inline constexpr double kMinBeadRadius_m = 1e-6;

/// Reads and checks a text bed (see above). Throws SceneError (field "bed.import") naming the
/// line of a malformed, non-finite or out-of-container bead, or the worst overlap.
/// The scene's bed.import_bytes, when set, are read instead of the file at `path`.
ImportedBed ReadTextBed(const std::string& path, const Scene& scene);
/// The same for a stream; `name` names it in messages.
ImportedBed ParseTextBed(std::istream& in, const std::string& name, const Scene& scene);

/// The SHA-256 (hex) of the bytes the scene imports: bed.import_sha256 when given, else of
/// bed.import_bytes or of the file bed.import names. Throws SceneError for a file it cannot
/// read.
std::string ImportContentSha256(const Scene& scene);

/// What the resource estimate needs of an imported bed: its beads, their smallest and largest
/// radius and the top of the highest (after the checks and any separating ReadTextBed does).
struct ImportedBedSize {
  double beads = 0.0;
  double min_radius_m = 0.0, max_radius_m = 0.0, top_m = 0.0;
};
/// The imported bed's size, read once for each content and the fields that shape it
/// (cylinder size, units, overlaps), then remembered (the last few hundred): the daemon
/// estimates every run of a sweep, and every job again as it queues and runs it. Throws as
/// ReadTextBed.
ImportedBedSize MeasureImportedBed(const Scene& scene);

}  // namespace dembuf
