#include "dembuf/study/bed/bed_io.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <sstream>
#include <unordered_map>
#include <vector>

#include "dembuf/study/bed/bed_formats.h"
#include "dembuf/study/scene/bed_plan.h"
#include "dembuf/study/scene/errors.h"
#include "dembuf/study/scene/species.h"
#include "dembuf/study/text/sha256.h"

namespace dembuf {

namespace {

// Moving beads apart aims below the accepted overlap, so that relaxing them does not push
// the next ones over it; it gives up after this many passes over the bed.
constexpr double kSeparationTarget = 0.5 * kMaxRestingOverlap;
constexpr int kSeparationPasses = 2000;

// A number of a bed file's message, to six digits.
std::string SixDigits(double v) {
  char text[32];
  std::snprintf(text, sizeof text, "%.6g", v);
  return std::string(text);
}

std::string Percent(double ratio) {
  char text[32];
  std::snprintf(text, sizeof text, "%.3g%%", 100 * ratio);
  return text;
}

// The most beads one cell of the grid below may hold: a cell of a size class is twice the
// class's largest diameter wide, and beads of that class (radii within a factor two) that do not
// overlap fit about 90 to a cell; this allows for overlapping ones.
constexpr std::size_t kMaxBeadsPerCell = 256;

// The beads in grids by size class, for finding the overlapping pairs in time linear in the
// beads (a bed file of one bead repeated 60,000 times took seconds in a single grid: every pair
// of a cell was tried). A class holds the beads whose radii lie within a factor two, in cells
// as wide as its largest diameter; a bead meets the beads of its own class and of every larger
// one in the 27 cells about it, where any bead it touches lies. A cell holding more than
// kMaxBeadsPerCell beads is crowded: more beads than fit there without overlapping.
class BeadGrid {
 public:
  explicit BeadGrid(const dem::ParticleState& beads) : m_beads(beads) {
    double r_min = INFINITY;
    for (double r : beads.radius) r_min = std::min(r_min, r);
    m_class.resize(beads.size());
    for (std::size_t i = 0; i < beads.size(); ++i) {
      const double ratio = beads.radius[i] / r_min;
      m_class[i] = std::isfinite(ratio) ? std::clamp(static_cast<int>(std::log2(ratio)), 0, 62) : 0;
      if (m_class[i] >= static_cast<int>(m_grids.size())) m_grids.resize(m_class[i] + 1);
      Grid& grid = m_grids[m_class[i]];
      grid.cell = std::max(grid.cell, 2.0 * beads.radius[i]);
    }
    const std::vector<std::size_t>* crowded = nullptr;
    for (std::size_t i = 0; i < beads.size(); ++i) {
      Grid& grid = m_grids[m_class[i]];
      std::vector<std::size_t>& cell = grid.cells[grid.Key(beads.position[i])];
      cell.push_back(i);
      if (cell.size() > kMaxBeadsPerCell && !crowded) crowded = &cell;
    }
    if (crowded) m_crowded = *crowded;
  }

  /// The beads of a crowded cell (empty when there is none): their pairs are not tried.
  const std::vector<std::size_t>& crowded() const { return m_crowded; }

  // Calls visit(i, j, overlap) for every overlapping pair, i < j (none when crowded).
  template <class Visit>
  void ForEachOverlap(Visit&& visit) const {
    if (!m_crowded.empty()) return;
    for (std::size_t i = 0; i < m_beads.size(); ++i) {
      const dem::Vec3& x = m_beads.position[i];
      for (std::size_t c = static_cast<std::size_t>(m_class[i]); c < m_grids.size(); ++c) {
        const Grid& grid = m_grids[c];
        if (grid.cells.empty()) continue;
        const long cx = grid.Index(x.x()), cy = grid.Index(x.y()), cz = grid.Index(x.z());
        for (long dx = -1; dx <= 1; ++dx)
          for (long dy = -1; dy <= 1; ++dy)
            for (long dz = -1; dz <= 1; ++dz) {
              const auto it = grid.cells.find(Hash(cx + dx, cy + dy, cz + dz));
              if (it == grid.cells.end()) continue;
              for (std::size_t j : it->second) {
                // Within its own class a pair is met from both beads: once is enough.
                if (static_cast<int>(c) == m_class[i] && j <= i) continue;
                const double overlap = m_beads.radius[i] + m_beads.radius[j] -
                                       (m_beads.position[j] - m_beads.position[i]).norm();
                if (overlap > 0.0) visit(std::min(i, j), std::max(i, j), overlap);
              }
            }
      }
    }
  }

 private:
  struct Grid {
    double cell = 0.0;  ///< twice the largest radius of the class
    std::unordered_map<long, std::vector<std::size_t>> cells;

    // A cell index, clamped: beads far away in cells of tiny beads would not fit in a long (a
    // bed file is checked for its beads' sizes and places after its overlaps are measured).
    long Index(double v) const {
      double index = std::floor(v / cell);
      if (!(std::abs(index) < 1e15)) index = index > 0.0 ? 1e15 : -1e15;  // NaN too
      return static_cast<long>(index);
    }
    long Key(const dem::Vec3& x) const { return Hash(Index(x.x()), Index(x.y()), Index(x.z())); }
  };

  // In unsigned arithmetic, whose products wrap where a long's would overflow.
  static long Hash(long ix, long iy, long iz) {
    const auto u = [](long v) { return static_cast<unsigned long>(v); };
    return static_cast<long>((u(ix) * 73856093UL) ^ (u(iy) * 19349663UL) ^ (u(iz) * 83492791UL));
  }

  const dem::ParticleState& m_beads;
  std::vector<int> m_class;   ///< each bead's size class: floor(log2(radius / smallest radius))
  std::vector<Grid> m_grids;  ///< by class
  std::vector<std::size_t> m_crowded;
};

// How far bead i sinks into the plate and into the side wall.
double PlateOverlap(const dem::ParticleState& b, std::size_t i) {
  return b.radius[i] - b.position[i].z();
}
double WallOverlap(const dem::ParticleState& b, std::size_t i, double wall_radius) {
  return std::hypot(b.position[i].x(), b.position[i].y()) + b.radius[i] - wall_radius;
}

struct Measured {
  OverlapStats pairs, plate, wall;
  std::size_t worst_i = 0, worst_j = 0;  // the worst pair
  std::size_t worst_plate = 0, worst_wall = 0;
  std::vector<std::size_t> crowded;  // beads of a cell holding more than fit (pairs not tried)
};

void Note(OverlapStats& stats, double ratio) {
  ++stats.contacts;
  stats.max_ratio = std::max(stats.max_ratio, ratio);
  stats.mean_ratio += ratio;  // a sum until Finish
}

void Finish(OverlapStats& stats) {
  if (stats.contacts > 0) stats.mean_ratio /= static_cast<double>(stats.contacts);
}

Measured MeasureOverlaps(const dem::ParticleState& b, double wall_radius) {
  Measured m;
  const BeadGrid grid(b);
  m.crowded = grid.crowded();
  grid.ForEachOverlap([&](std::size_t i, std::size_t j, double overlap) {
    const double ratio = overlap / std::min(b.radius[i], b.radius[j]);
    if (ratio > m.pairs.max_ratio) {
      m.worst_i = i;
      m.worst_j = j;
    }
    Note(m.pairs, ratio);
  });
  for (std::size_t i = 0; i < b.size(); ++i) {
    if (const double plate = PlateOverlap(b, i) / b.radius[i]; plate > 0.0) {
      if (plate > m.plate.max_ratio) m.worst_plate = i;
      Note(m.plate, plate);
    }
    if (const double wall = WallOverlap(b, i, wall_radius) / b.radius[i]; wall > 0.0) {
      if (wall > m.wall.max_ratio) m.worst_wall = i;
      Note(m.wall, wall);
    }
  }
  Finish(m.pairs);
  Finish(m.plate);
  Finish(m.wall);
  return m;
}

double Worst(const Measured& m) {
  return std::max({m.pairs.max_ratio, m.plate.max_ratio, m.wall.max_ratio});
}

// Moves overlapping beads apart until no overlap passes kSeparationTarget of a radius: each
// pass pushes every bead out of the plate and the wall and every overlapping pair apart along
// its line of centres, each bead by half the excess. Returns false if passes run out.
bool Separate(dem::ParticleState& b, double wall_radius) {
  for (int pass = 0; pass < kSeparationPasses; ++pass) {
    bool moved = false;
    for (std::size_t i = 0; i < b.size(); ++i) {
      const double r = b.radius[i];
      if (PlateOverlap(b, i) > kSeparationTarget * r) {
        b.position[i].z() = r * (1.0 - 0.5 * kSeparationTarget);
        moved = true;
      }
      if (const double wall = WallOverlap(b, i, wall_radius); wall > kSeparationTarget * r) {
        const double rho = std::hypot(b.position[i].x(), b.position[i].y());
        const double inward = (rho - (wall - 0.5 * kSeparationTarget * r)) / rho;
        b.position[i].x() *= inward;
        b.position[i].y() *= inward;
        moved = true;
      }
    }
    const BeadGrid grid(b);
    if (!grid.crowded().empty()) return false;
    grid.ForEachOverlap([&](std::size_t i, std::size_t j, double overlap) {
      const double r_min = std::min(b.radius[i], b.radius[j]);
      if (overlap <= kSeparationTarget * r_min) return;
      const dem::Vec3 d = b.position[j] - b.position[i];
      const double dist = d.norm();
      const dem::Vec3 n = dist > 0.0 ? dem::Vec3(d / dist) : dem::Vec3::UnitZ();
      const double half = 0.5 * (overlap - 0.5 * kSeparationTarget * r_min);
      b.position[i] -= half * n;
      b.position[j] += half * n;
      moved = true;
    });
    if (!moved) return true;
  }
  return Worst(MeasureOverlaps(b, wall_radius)) <= kMaxRestingOverlap;
}

}  // namespace

std::string ImportedBed::Describe() const {
  std::ostringstream out;
  auto part = [&](const char* what, const OverlapStats& s, const char* noun, const char* of) {
    out << what << s.contacts << noun;
    if (s.contacts > 0)
      out << ", overlap at most " << Percent(s.max_ratio) << " of " << of << " (mean "
          << Percent(s.mean_ratio) << ")";
  };
  out << beads.size() << " beads (" << BedFileFormatName(format) << " file)";
  if (species > 1) {
    std::vector<std::size_t> count(static_cast<std::size_t>(species), 0);
    for (const dem::Species k : beads.species) ++count[k];
    out << "; atom types as species:";
    for (std::size_t k = 0; k < count.size(); ++k)
      out << (k ? ", " : " ") << "type " << k + 1 << " species " << k + 1 << " (" << count[k]
          << " beads)";
  }
  part("; resting on the plate: ", plate, " beads", "a radius");
  part("; touching the side wall: ", wall, " beads", "a radius");
  part("; bead pairs touching: ", pairs, "", "the smaller radius");
  if (moved > 0) {
    char move[32];
    std::snprintf(move, sizeof move, "%.3g mm", 1e3 * max_move_m);
    out << "; separated: " << moved << " beads moved, at most " << move
        << ", the largest overlap from " << Percent(max_ratio_before) << " to "
        << Percent(std::max({pairs.max_ratio, plate.max_ratio, wall.max_ratio}));
  }
  return out.str();
}

namespace {

// The species (0-based) of a bead of atom type `type`: type k is species k for a scene of
// bed.import_types > 1; every type is species 1 otherwise. `fail` names the bead's line.
template <class Fail>
int SpeciesOfType(double type, const Scene& scene, const Fail& fail) {
  const auto types = static_cast<double>(scene.bed.import_types);
  if (types <= 1) return 0;
  if (!(type >= 1 && type <= types && type == std::floor(type)))
    fail("atom type " + SixDigits(type) + " is none of 1 to " + SixDigits(types) +
         " (bed.import_types = " + SixDigits(types) + ": type k is species k)");
  return static_cast<int>(type) - 1;
}

// Where the file disagrees with the scene (its beads' densities, their sizes, types it has
// that the scene does not tell apart): said in the bed's warnings, not silently replaced.
void AddImportWarnings(const BeadRecords& records, const Scene& scene, ImportedBed& bed) {
  const int species = SpeciesCount(scene);
  std::vector<std::size_t> other_density(species, 0);
  std::vector<double> file_density(species, 0.0);
  double highest_type = 1;
  for (std::size_t i = 0; i < records.beads.size(); ++i) {
    const BeadRecord& b = records.beads[i];
    highest_type = std::max(highest_type, b.type);
    const dem::Species kind = bed.beads.species[i];
    const double rho = SpeciesOf(scene, kind).density_kg_m3;
    if (b.density_kg_m3 > 0.0 && std::abs(b.density_kg_m3 - rho) > 0.01 * rho) {
      if (other_density[kind]++ == 0) file_density[kind] = b.density_kg_m3;
    }
  }
  if (highest_type > 1 && scene.bed.import_types == 1)
    bed.warnings.push_back("bed.import: the file's beads have atom types up to " +
                           SixDigits(highest_type) +
                           "; with bed.import_types = 1 every bead is species 1");
  for (int kind = 0; kind < species; ++kind) {
    const SpeciesMaterial m = SpeciesOf(scene, kind);
    const std::string density_field = kind == 0
                                          ? "material.density_kg_m3"
                                          : "species" + std::to_string(kind + 1) + ".density_kg_m3";
    // (A bed of one species is spoken of as its beads, one of several by species number: the
    // bed, and these warnings with it, are kept under a key its species' names are not in.)
    const std::string number = std::to_string(kind + 1);
    const std::string of = species > 1 ? " of species " + number : "";
    if (other_density[kind] > 0)
      bed.warnings.push_back("bed.import: the file gives " + std::to_string(other_density[kind]) +
                             " beads" + of + " another density (" + SixDigits(file_density[kind]) +
                             " kg/m^3 the first); the run gives " +
                             (species > 1 ? "them " : "every bead ") + density_field + " = " +
                             SixDigits(m.density_kg_m3) + " kg/m^3");
    double r_min = HUGE_VAL, r_max = 0.0;
    for (std::size_t i = 0; i < bed.beads.size(); ++i)
      if (bed.beads.species[i] == kind) {
        r_min = std::min(r_min, bed.beads.radius[i]);
        r_max = std::max(r_max, bed.beads.radius[i]);
      }
    if (r_max == 0.0) continue;  // none of this species
    const double d_min = m.diameter_min_m, d_max = m.diameter_max_m;
    const std::string sizes = kind == 0 ? "beads.diameter_min_m"
                                        : "species" + std::to_string(kind + 1) + ".diameter_min_m";
    if (2 * r_min < 0.99 * d_min || 2 * r_max > 1.01 * d_max)
      bed.warnings.push_back(
          "bed.import: the file's " +
          (species > 1 ? "diameters of species " + number : std::string("bead diameters")) + ", " +
          SixDigits(2e3 * r_min) + " to " + SixDigits(2e3 * r_max) +
          " mm, lie outside the scene's " + sizes + " to diameter_max_m, " +
          SixDigits(1e3 * d_min) + " to " + SixDigits(1e3 * d_max) +
          " mm; the run uses the file's");
  }
}

}  // namespace

ImportedBed ParseTextBed(std::istream& in, const std::string& name, const Scene& scene) {
  ImportedBed bed;
  const double R = scene.cylinder.radius_m;
  const BeadRecords records = ReadBeadRecords(in, name, scene.bed.import_units, kMaxBeads);
  bed.format = records.format;
  // A bead too large for the container, read in metres, may be a file in another unit: the
  // unit that makes it fit is named.
  auto unit_hint = [&](double radius_m) -> std::string {
    if (scene.bed.import_units != "m") return "";
    for (const auto& [unit, factor] : {std::pair{"mm", 1e-3}, std::pair{"cm", 1e-2}})
      if (radius_m * factor < 0.5 * R && radius_m * factor >= kMinBeadRadius_m)
        return std::string("; if the file is in ") +
               (factor == 1e-3 ? "millimetres" : "centimetres") + ", set bed.import_units = \"" +
               unit + "\"";
    return "";
  };
  for (const BeadRecord& b : records.beads) {
    auto fail = [&](const std::string& why) {
      throw SceneError("bed.import", name + ":" + std::to_string(b.line) + ": " + why);
    };
    const double x = b.x, y = b.y, z = b.z, r = b.radius;
    if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z) || !std::isfinite(r))
      fail("non-finite value");
    if (!(r >= kMinBeadRadius_m))
      fail("radius " + SixDigits(r) + " m is below " + SixDigits(kMinBeadRadius_m) +
           " m, the smallest bead this model covers (finer powders are held by adhesion and the "
           "air, which it leaves out; a file in millimetres needs bed.import_units = \"mm\")");
    if (r >= 0.5 * R)
      fail("radius " + SixDigits(r) + " m must be below half the cylinder's radius" + unit_hint(r));
    // Outside the container: no overlap to accept or separate.
    if (std::hypot(x, y) + 0.5 * r > R)
      fail("bead reaches outside the cylinder (radius " + SixDigits(R) + " m)" + unit_hint(r));
    if (z < 0.5 * r)
      fail("bead reaches below the plate (its centre is at z = " + SixDigits(z) + ")");
    if (z + r > scene.cylinder.height_m)
      fail("bead reaches above the side wall (cylinder.height_m = " +
           SixDigits(scene.cylinder.height_m) + " m)");
    const int kind = SpeciesOfType(b.type, scene, fail);
    bed.beads.Add(dem::Vec3(x, y, z), r, SpeciesOf(scene, kind).density_kg_m3,
                  static_cast<dem::Species>(kind));
    bed.lines.push_back(b.line);
  }
  if (bed.beads.size() == 0) throw SceneError("bed.import", name + " holds no beads");
  AddImportWarnings(records, scene, bed);
  bed.species = static_cast<int>(scene.bed.import_types);

  Measured m = MeasureOverlaps(bed.beads, R);
  if (!m.crowded.empty()) {
    // A pile no relaxation makes a bed of: refused before its pairs are tried.
    std::string lines;
    for (std::size_t k = 0; k < std::min<std::size_t>(m.crowded.size(), 5); ++k)
      lines += (k ? ", " : "") + std::to_string(bed.lines[m.crowded[k]]);
    throw SceneError("bed.import", name + ": " + std::to_string(m.crowded.size()) +
                                       " beads lie in one place (lines " + lines +
                                       ", ...), more than fit there without overlapping: is a "
                                       "bead repeated, or the file's units wrong?");
  }
  bed.max_ratio_before = Worst(m);
  if (bed.max_ratio_before > kMaxRestingOverlap && scene.bed.import_overlaps == "relax") {
    const std::vector<dem::Vec3> before = bed.beads.position;
    if (!Separate(bed.beads, R))
      throw SceneError("bed.import", name + ": the beads could not be separated within " +
                                         std::to_string(kSeparationPasses) +
                                         " passes; the bed is too crowded for its container");
    for (std::size_t i = 0; i < before.size(); ++i) {
      const double move = (bed.beads.position[i] - before[i]).norm();
      bed.moved += move > 0.0;
      bed.max_move_m = std::max(bed.max_move_m, move);
    }
    m = MeasureOverlaps(bed.beads, R);
  }
  const std::string hint =
      "; a settled bed's resting contacts overlap by far less (at most " +
      Percent(kMaxRestingOverlap) +
      " is accepted): separate them, or set bed.import_overlaps = \"relax\" to have them moved "
      "apart";
  const auto at_line = [&](std::size_t i) { return name + ":" + std::to_string(bed.lines[i]); };
  if (m.pairs.max_ratio > kMaxRestingOverlap)
    throw SceneError("bed.import",
                     name + ": the beads of lines " + std::to_string(bed.lines[m.worst_i]) +
                         " and " + std::to_string(bed.lines[m.worst_j]) + " overlap by " +
                         Percent(m.pairs.max_ratio) + " of the smaller radius" + hint);
  if (m.plate.max_ratio > kMaxRestingOverlap)
    throw SceneError("bed.import", at_line(m.worst_plate) + ": the bead sinks into the plate by " +
                                       Percent(m.plate.max_ratio) + " of its radius" + hint);
  if (m.wall.max_ratio > kMaxRestingOverlap)
    throw SceneError("bed.import", at_line(m.worst_wall) +
                                       ": the bead sinks into the side wall by " +
                                       Percent(m.wall.max_ratio) + " of its radius" + hint);
  bed.pairs = m.pairs;
  bed.plate = m.plate;
  bed.wall = m.wall;
  return bed;
}

std::string ImportContentSha256(const Scene& scene) {
  if (!scene.bed.import_sha256.empty()) return scene.bed.import_sha256;
  if (scene.bed.import_bytes) return Sha256Hex(*scene.bed.import_bytes);
  std::error_code error;
  if (!std::filesystem::is_regular_file(scene.bed.import, error))
    throw SceneError("bed.import",
                     "file \"" + scene.bed.import + "\" does not exist or is not a file");
  std::ifstream in(scene.bed.import, std::ios::binary);
  if (!in) throw SceneError("bed.import", "cannot read \"" + scene.bed.import + "\"");
  Sha256Stream digest;
  char block[1 << 16];
  while (in.read(block, sizeof block) || in.gcount() > 0)
    digest.Add(std::string_view(block, static_cast<std::size_t>(in.gcount())));
  return digest.Hex();
}

ImportedBedSize MeasureImportedBed(const Scene& scene) {
  // What ReadTextBed's result depends on: the content, the container it is checked against,
  // the unit of its numbers and what is done with overlaps.
  std::ostringstream key;
  key.precision(17);
  key << ImportContentSha256(scene) << ' ' << scene.cylinder.radius_m << ' '
      << scene.cylinder.height_m << ' ' << scene.bed.import_units << ' '
      << scene.bed.import_overlaps;
  static std::mutex mutex;
  static std::map<std::string, ImportedBedSize> measured;
  {
    std::lock_guard lock(mutex);
    if (const auto it = measured.find(key.str()); it != measured.end()) return it->second;
  }
  const ImportedBed imported = ReadTextBed(scene.bed.import, scene);
  ImportedBedSize size;
  size.beads = static_cast<double>(imported.beads.size());
  for (std::size_t i = 0; i < imported.beads.size(); ++i) {
    const double r = imported.beads.radius[i];
    size.min_radius_m = i == 0 ? r : std::min(size.min_radius_m, r);
    size.max_radius_m = std::max(size.max_radius_m, r);
    size.top_m = std::max(size.top_m, imported.beads.position[i].z() + r);
  }
  std::lock_guard lock(mutex);
  if (measured.size() >= 256) measured.clear();  // a few hundred files' sizes at most
  measured.emplace(key.str(), size);
  return size;
}

ImportedBed ReadTextBed(const std::string& path, const Scene& scene) {
  if (scene.bed.import_bytes) {
    std::istringstream in(*scene.bed.import_bytes);
    return ParseTextBed(in, path, scene);
  }
  std::error_code error;
  if (!std::filesystem::is_regular_file(path, error))
    throw SceneError("bed.import", "\"" + path + "\" does not exist or is not a file");
  if (const auto size = std::filesystem::file_size(path, error); !error && size > kMaxBedFileBytes)
    throw SceneError("bed.import", "\"" + path + "\" holds " + std::to_string(size) +
                                       " bytes; a bed file may hold at most " +
                                       std::to_string(kMaxBedFileBytes));
  std::ifstream in(path);
  if (!in) throw SceneError("bed.import", "cannot open \"" + path + "\"");
  return ParseTextBed(in, path, scene);
}

}  // namespace dembuf
