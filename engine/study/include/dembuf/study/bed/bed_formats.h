// The bead files other codes write, read into one list of beads: dembuf's plain text (x y z
// radius a line, with an optional header naming the columns and their units), LAMMPS data
// files (atom style sphere, or LIGGGHTS' granular: id type diameter density x y z) and LAMMPS
// dump files (the last frame; columns by name). The format is told from the file itself.
// Every value is checked by the caller (bed_io.h); here only the file's shape is.
#pragma once

#include <cstddef>
#include <istream>
#include <string>
#include <vector>

namespace dembuf {

/// The largest bed file read, and its longest line.
inline constexpr std::size_t kMaxBedFileBytes = std::size_t{512} << 20;
inline constexpr std::size_t kMaxBedLineBytes = 4096;

/// A bead as a file gives it, in metres, with the line it came from.
struct BeadRecord {
  double x = 0, y = 0, z = 0, radius = 0;
  long line = 0;
  double density_kg_m3 = 0;  ///< as the file gives it (0: the format has none)
  double type = 1;           ///< its atom type or species column (1: the format has none)
};

/// The bed file formats dembuf reads.
enum class BedFileFormat { kText, kLammpsData, kLammpsDump };
/// The format's name for messages: "text", "LAMMPS data" or "LAMMPS dump".
const char* BedFileFormatName(BedFileFormat format);

struct BeadRecords {
  BedFileFormat format = BedFileFormat::kText;
  std::vector<BeadRecord> beads;
};

/// The length units a bed file may be written in (bed.import_units, or a text header's
/// column), and metres per unit; 0 for a name that is none of them.
double MetresPerUnit(const std::string& unit);

/// Reads the beads of `in` (named `name` in messages), lengths in `unit` unless a text
/// header states its own. Throws SceneError (field bed.import) naming the line and what was
/// expected. Reads at most `max_beads` beads.
BeadRecords ReadBeadRecords(std::istream& in, const std::string& name, const std::string& unit,
                            double max_beads);

}  // namespace dembuf
