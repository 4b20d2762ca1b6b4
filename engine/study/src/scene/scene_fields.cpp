#include "dembuf/study/scene/scene_fields.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <numbers>
#include <optional>
#include <ostream>
#include <sstream>
#include <toml.hpp>
#include <tuple>

#include "dembuf/study/scene/bed_plan.h"
#include "dembuf/study/scene/contact_setup.h"
#include "dembuf/study/scene/errors.h"
#include "dembuf/study/scene/species.h"
#include "dembuf/study/text/text_limits.h"
#include "scene/field_row.h"

namespace dembuf {
namespace {

constexpr double kUnbounded = 1e300;

// The longest free flight a scene may ask for, as long as the longest run (time.end_s). The
// flight is computed, not stepped, but the run's clock must still resolve a time step after
// it, and a flight of 1e299 s is a typing error.
constexpr double kMaxFlightTime_s = 1e3;

// The limits of scene text, and of the strings and lists a field takes from anywhere (files,
// `--set`, requests): a list longer than a TOML array may be, or a string longer than a path.
const TomlLimits kSceneLimits;

// Whether `path` names a regular file. A name the system refuses to look up (too long, say)
// names no file: the caller reports it as such, instead of the library throwing.
bool IsRegularFile(const std::string& path) {
  std::error_code ignored;
  return std::filesystem::is_regular_file(path, ignored);
}

// Ranges are wide enough for any physical scene the engine can handle and tight enough to
// catch unit slips (millimetres typed as metres, GPa typed as Pa). The table in three parts:
// the container, the beads' material and sizes.
std::vector<SceneField> WorldFields() {
  std::vector<SceneField> fields = {
      {"gravity_m_s2", "m/s^2", "gravitational acceleration, downward", Shapes::kSourceBed,
       DEMBUF_FIELD(gravity_m_s2), 0.0, 1000.0},

      {"cylinder.radius_m", "m", "inner radius of the cylinder (paper: 0.095)", Shapes::kSourceBed,
       DEMBUF_FIELD(cylinder.radius_m), 0.0, 5.0, true},
      {"cylinder.height_m", "m", "height H2 of the side wall", Shapes::kSourceBed,
       DEMBUF_FIELD(cylinder.height_m), 0.0, 10.0, true},

      {"material.name", "", "name of species 1, these beads (summaries, frames, bed files)",
       Shapes::kOutput, DEMBUF_FIELD(material.name)},
      {"material.density_kg_m3", "kg/m^3", "bead density rho", Shapes::kSourceBed,
       DEMBUF_FIELD(material.density_kg_m3), 0.0, 1e5, true},
      {"material.youngs_modulus_Pa", "Pa", "Young's modulus E of beads and projectile",
       Shapes::kSourceBed, DEMBUF_FIELD(material.youngs_modulus_Pa), 0.0, 1e13, true},
      {"material.poisson_ratio", "", "Poisson ratio nu of beads and projectile", Shapes::kSourceBed,
       DEMBUF_FIELD(material.poisson_ratio), 0.0, 0.5, false, true},
  };
  // The physics parts' rows (field_row.h), in the table's order.
  for (const auto& part :
       {HertzNormalFields(), MindlinTangentialFields(), RollingResistanceFields()})
    fields.insert(fields.end(), part.begin(), part.end());
  fields.insert(fields.end(),
                {
                    {"material.shear_stiffness",
                     "",
                     "G* formula: paper = G/(2(1-nu)) (kt/kn = 2), mindlin = G/(2(2-nu))",
                     Shapes::kSourceBed,
                     DEMBUF_FIELD(material.shear_stiffness),
                     0.0,
                     0.0,
                     false,
                     false,
                     {"paper", "mindlin"}},

                    {"walls.material_from_beads", "", "plate and wall take the beads' E and nu",
                     Shapes::kSourceBed, DEMBUF_FIELD(walls.material_from_beads)},
                    {"walls.youngs_modulus_Pa", "Pa", "E of plate and wall, if not from beads",
                     Shapes::kSourceBed, DEMBUF_FIELD(walls.youngs_modulus_Pa), 0.0, 1e13, true},
                    {"walls.poisson_ratio", "", "nu of plate and wall, if not from beads",
                     Shapes::kSourceBed, DEMBUF_FIELD(walls.poisson_ratio), 0.0, 0.5, false, true},

                    {"beads.diameter_min_m", "m", "smallest bead diameter (uniform distribution)",
                     Shapes::kSourceBed, DEMBUF_FIELD(beads.diameter_min_m), 0.0, 1.0, true},
                    {"beads.diameter_max_m", "m", "largest bead diameter (uniform distribution)",
                     Shapes::kSourceBed, DEMBUF_FIELD(beads.diameter_max_m), 0.0, 1.0, true},
                });
  const std::vector<SceneField> species = SpeciesPairsFields();
  fields.insert(fields.end(), species.begin(), species.end());
  return fields;
}

// how the bed is made or imported.
std::vector<SceneField> BedFields() {
  return {
      {"bed.thickness_m", "m", "settled bed thickness H; 0 = no beads", Shapes::kCutBed,
       DEMBUF_FIELD(bed.thickness_m), 0.0, 10.0},
      {"bed.prep_friction", "", "bead friction while the bed settles (sets the packing C0)",
       Shapes::kSourceBed, DEMBUF_FIELD(bed.prep_friction), 0.0, 10.0},
      {"bed.seed", "", "random seed of the bead insertion", Shapes::kSourceBed,
       DEMBUF_FIELD(bed.seed), 0.0, 1e15},
      {"bed.import", "",
       "bed file: text (x y z radius a line, or a header naming the columns), LAMMPS data "
       "(atom style sphere) or LAMMPS dump (its last frame); empty = prepare",
       Shapes::kImportedBed, DEMBUF_FIELD(bed.import)},
      {"bed.import_units",
       "",
       "length unit of bed.import's numbers",
       Shapes::kImportedBed,
       DEMBUF_FIELD(bed.import_units),
       0.0,
       0.0,
       false,
       false,
       {"m", "cm", "mm", "um"}},
      {"bed.import_types",
       "",
       "how many species bed.import's atom types are (type k is species k); 1 = all species 1",
       Shapes::kImportedBed,
       DEMBUF_FIELD(bed.import_types),
       1.0,
       kMaxSpecies,
       false,
       false,
       {},
       +[](const Scene& s) { return s.bed.import_types > 1; }},
      {"bed.import_overlaps",
       "",
       "beads of bed.import overlapping by more than 1% of a radius: refuse, or relax (separate)",
       Shapes::kImportedBed,
       DEMBUF_FIELD(bed.import_overlaps),
       0.0,
       0.0,
       false,
       false,
       {"refuse", "relax"}},
      {"bed.source_thickness_m", "m", "thickness of the settled bed every H is cut from",
       Shapes::kSourceBed, DEMBUF_FIELD(bed.source_thickness_m), 0.0, 10.0, true},
      {"bed.cut",
       "",
       "how a bed is cut to H: surface = mean surface at H, tops = every bead top below H",
       Shapes::kEveryCut,
       DEMBUF_FIELD(bed.cut),
       0.0,
       0.0,
       false,
       false,
       {"surface", "tops"}},
      {"bed.settle_tolerance", "", "rest: kinetic energy per bead below this times m g d",
       Shapes::kSourceBed, DEMBUF_FIELD(bed.settle_tolerance), 0.0, 1.0, true},
      {"bed.friction_settle_tolerance", "",
       "the same after the friction change; 0 = bed.settle_tolerance", Shapes::kFrictionBed,
       DEMBUF_FIELD(bed.friction_settle_tolerance), 0.0, 1.0},
      {"bed.quench_cut_relaxation", "",
       "relax a cut bed with kinetic damping (zero velocities at each kinetic-energy peak)",
       Shapes::kEveryCut, DEMBUF_FIELD(bed.quench_cut_relaxation)},
      {"bed.local_settling", "",
       "settle beds by stepping only the last moving beads' neighbourhood (false: every bead)",
       Shapes::kSourceBed, DEMBUF_FIELD(bed.local_settling)},
      {"bed.quench_cut_beads", "",
       "in a cut bed's local settling, stop each bead whose kinetic energy passes a maximum",
       Shapes::kEveryCut, DEMBUF_FIELD(bed.quench_cut_beads)},
      {"bed.cut_alpha", "",
       "time-step factor of the relaxation of the bed cut to H: dt = cut_alpha * critical step of "
       "eq. 6, from time.alpha to 1; 0 = automatic (4 x time.alpha, at most 0.8; time.alpha "
       "with bed.quench_cut_relaxation)",
       Shapes::kCutBed, DEMBUF_FIELD(bed.cut_alpha), 0.0, 1.0},
      {"bed.soft_settling", "",
       "settle the source bed with E divided by this, then restore E and relax; 0 = automatic "
       "(up to 100, within the pour's overlap limit), 1 = off",
       Shapes::kSourceBed, DEMBUF_FIELD(bed.soft_settling), 0.0, 1000.0},
      {"bed.max_settle_s", "s", "simulated time allowed for settling before giving up",
       Shapes::kNothing, DEMBUF_FIELD(bed.max_settle_s), 0.0, 1e3, true},
      {"bed.friction_ramp_s", "s", "duration of the slow change from prep_friction to mu_pp",
       Shapes::kFrictionBed, DEMBUF_FIELD(bed.friction_ramp_s), 0.0, 10.0},
  };
}

// the projectile, the run's times and its output.
std::vector<SceneField> ImpactFields() {
  std::vector<SceneField> fields = {
      {"projectile.enabled", "", "drop a projectile", Shapes::kImpact,
       DEMBUF_FIELD(projectile.enabled)},
      {"projectile.diameter_m", "m", "projectile diameter D", Shapes::kImpact,
       DEMBUF_FIELD(projectile.diameter_m), 0.0, 10.0, true},
      {"projectile.mass_kg", "kg", "projectile mass M", Shapes::kImpact,
       DEMBUF_FIELD(projectile.mass_kg), 0.0, 1e6, true},
      {"projectile.speed_m_s", "m/s", "initial downward speed V0", Shapes::kImpact,
       DEMBUF_FIELD(projectile.speed_m_s), 0.0, 1000.0},
      {"projectile.height_m", "m", "H1, initial centre height above the bed surface",
       Shapes::kImpact, DEMBUF_FIELD(projectile.height_m), 0.0, 100.0, true},
      {"projectile.offset_m", "m",
       "horizontal distance of the drop line from the axis (radius - diameter/2 grazes the wall)",
       Shapes::kImpact, DEMBUF_FIELD(projectile.offset_m), 0.0, 100.0},
  };
  const std::vector<SceneField> damping = BeadDampingFields();
  fields.insert(fields.end(), damping.begin(), damping.end());
  fields.insert(
      fields.end(),
      {
          {"time.alpha", "", "time-step factor: dt = alpha * critical step of eq. 6 (at most 1)",
           Shapes::kSourceBed, DEMBUF_FIELD(time.alpha), 0.0, 1.0, true},
          {"time.end_s", "s", "end time; 0 = stop when the impact is over", Shapes::kImpact,
           DEMBUF_FIELD(time.end_s), 0.0, 1e3},
          {"time.impact_window_s", "s", "automatic end: at most this long after the first contact",
           Shapes::kImpact, DEMBUF_FIELD(time.impact_window_s), 0.0, 1e3, true},
          {"time.output_interval_s", "s", "spacing of the written force samples", Shapes::kOutput,
           DEMBUF_FIELD(time.output_interval_s), 0.0, 1.0, true},

          {"output.snapshot_times_s", "s",
           "times of contact-network snapshots (force chains, plate map, force PDF)",
           Shapes::kOutput, DEMBUF_FIELD(output.snapshot_times_s), 0.0, 1e3},
          {"output.snapshot_after_contact_s", "s",
           "snapshot times counted from the projectile's first contact", Shapes::kOutput,
           DEMBUF_FIELD(output.snapshot_after_contact_s), 0.0, 1e3},
          {"output.snapshot_at_peak", "", "also snapshot at the peak plate force (runs twice)",
           Shapes::kOutput, DEMBUF_FIELD(output.snapshot_at_peak)},
          {"output.chain_slab_width_m", "m",
           "width of the vertical slice through the axis drawn in force-chain pictures",
           Shapes::kOutput, DEMBUF_FIELD(output.chain_slab_width_m), 0.0, 10.0, true},
          {"output.animation_interval_s", "s",
           "spacing of animation frames of the beads during the impact (frames/, for ParaView); "
           "0 = none",
           Shapes::kOutput, DEMBUF_FIELD(output.animation_interval_s), 0.0, 1.0},
          {"output.frame_format",
           "",
           "the animation frames' files: vtp (frames/*.vtp and frames.pvd, for ParaView), lammps "
           "(frames/*.dump, LAMMPS dump files for OVITO) or both",
           Shapes::kOutput,
           DEMBUF_FIELD(output.frame_format),
           0.0,
           0.0,
           false,
           false,
           {"vtp", "lammps", "both"}},
      });
  return fields;
}

const std::vector<SceneField>& FieldTable() {
  static const std::vector<SceneField> table = [] {
    std::vector<SceneField> all = WorldFields();
    for (auto part : {BedFields(), ImpactFields()}) all.insert(all.end(), part.begin(), part.end());
    return all;
  }();
  return table;
}

std::string FormatNumber(double v) {
  char buf[64];
  auto [end, ec] = std::to_chars(buf, buf + sizeof buf, v);
  std::string s(buf, end);
  // Keep it a TOML float, so that the printed scene reads back with the same types.
  if (std::isfinite(v) && s.find_first_of(".e") == std::string::npos) s += ".0";
  return s;
}

// A number for a message: 3 significant digits.
std::string FormatShort(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g", v);
  return buf;
}

std::string RangeText(const SceneField& f) {
  std::ostringstream out;
  out << "must be " << (f.min_open ? "> " : ">= ") << FormatNumber(f.min);
  if (f.max < kUnbounded) out << " and " << (f.max_open ? "< " : "<= ") << FormatNumber(f.max);
  if (!f.unit.empty()) out << " (" << f.unit << ")";
  return out.str();
}

void CheckRange(const SceneField& f, double v, std::string_view as_text) {
  if (!std::isfinite(v))
    throw SceneError(std::string(f.name), std::string(as_text) + " is not a finite number");
  bool below = f.min_open ? v <= f.min : v < f.min;
  bool above = f.max_open ? v >= f.max : v > f.max;
  if (below || above)
    throw SceneError(std::string(f.name),
                     std::string(as_text) + " is out of range: " + RangeText(f));
}

// The edit distance of two names (insertions, deletions and substitutions), for "did you
// mean": a dozen lines, where a library would be a dependency for one error message.
std::size_t EditDistance(std::string_view a, std::string_view b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diagonal = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t substitution = diagonal + (a[i - 1] == b[j - 1] ? 0 : 1);
      diagonal = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, substitution});
    }
  }
  return row[b.size()];
}

// "did you mean bed.thickness_m? " for a name a third of whose letters or fewer are wrong.
std::string DidYouMean(std::string_view name) {
  constexpr std::size_t kLongestMisspelling = 64;  // field names are at most 40 letters
  if (name.size() > kLongestMisspelling) return "";
  const SceneField* nearest = nullptr;
  std::size_t best = name.size() / 3 + 1;
  for (const auto& f : FieldTable()) {
    if (const std::size_t d = EditDistance(name, f.name); d < best) {
      best = d;
      nearest = &f;
    }
  }
  return nearest ? "did you mean " + std::string(nearest->name) + "? " : "";
}

std::string KnownFieldsNear(std::string_view name) {
  std::string section(name.substr(0, name.find('.')));
  std::string list;
  for (const auto& f : FieldTable()) {
    if (f.name.substr(0, f.name.find('.')) != section) continue;
    if (!list.empty()) list += ", ";
    list += f.name;
  }
  if (list.empty()) {
    std::map<std::string_view, bool> sections;
    for (const auto& f : FieldTable()) sections[f.name.substr(0, f.name.find('.'))] = true;
    for (const auto& [s, unused] : sections) list += (list.empty() ? "" : ", ") + std::string(s);
    return "known sections and fields: " + list;
  }
  return "known fields here: " + list;
}

// Fields withdrawn from the table. A scene written before (a run folder's scene.toml, a stored
// job) may still name one with the value that does what the engine now does; any other value
// is refused with the reason.
struct WithdrawnField {
  std::string_view name, kept_value, why;
};
constexpr WithdrawnField kWithdrawnFields[] = {
    {"bed.quench_cut_column", "false",
     "withdrawn: the cut beds it made were not at rest (docs/accuracy-cost.md)"},
};

const WithdrawnField* FindWithdrawnField(std::string_view name) {
  for (const WithdrawnField& field : kWithdrawnFields)
    if (field.name == name) return &field;
  return nullptr;
}

// Whether `name` is a withdrawn field set to its kept value (`text`, as a scene file writes
// it), which is then skipped; throws for another value.
bool SkipsWithdrawnField(std::string_view name, std::string_view text) {
  const WithdrawnField* field = FindWithdrawnField(name);
  if (!field) return false;
  if (text == field->kept_value) return true;
  throw SceneError(std::string(name), std::string(field->why) + "; only " +
                                          std::string(field->kept_value) +
                                          ", what the engine does now, is still read");
}

}  // namespace

const SceneField& RequireSceneField(std::string_view name) {
  const SceneField* f = FindSceneField(name);
  if (const WithdrawnField* withdrawn = f ? nullptr : FindWithdrawnField(name))
    throw SceneError(std::string(name), std::string(withdrawn->why));
  if (!f)
    throw SceneError(std::string(name),
                     "unknown field; " + DidYouMean(name) + KnownFieldsNear(name));
  return *f;
}

namespace {

void SetNumber(Scene& scene, const SceneField& f, double v, std::string_view text) {
  CheckRange(f, v, text);
  if (auto* get = std::get_if<double& (*)(Scene&)>(&f.ref)) {
    (*get)(scene) = v;
  } else if (auto* geti = std::get_if<std::int64_t& (*)(Scene&)>(&f.ref)) {
    if (v != std::floor(v))
      throw SceneError(std::string(f.name), std::string(text) + " is not a whole number");
    (*geti)(scene) = static_cast<std::int64_t>(v);
  }
}

void SetString(Scene& scene, const SceneField& f, std::string_view v) {
  if (v.size() > kSceneLimits.max_string)
    throw SceneError(std::string(f.name), "a value of " + std::to_string(v.size()) +
                                              " bytes; at most " +
                                              std::to_string(kSceneLimits.max_string) + " bytes");
  if (!f.choices.empty() && std::find(f.choices.begin(), f.choices.end(), v) == f.choices.end()) {
    std::string allowed;
    for (auto c : f.choices) allowed += (allowed.empty() ? "" : ", ") + std::string(c);
    throw SceneError(std::string(f.name),
                     "\"" + std::string(v) + "\" is not allowed; choose one of: " + allowed);
  }
  std::get<std::string& (*)(Scene&)>(f.ref)(scene) = std::string(v);
}

const char* TypeName(const SceneField::Ref& ref) {
  switch (ref.index()) {
    case 0:
      return "a number";
    case 1:
      return "a whole number";
    case 2:
      return "true or false";
    default:
      return "a string";
  }
}

const char* TomlTypeName(const toml::value& v) {
  if (v.is_string()) return "a string";
  if (v.is_boolean()) return "a boolean";
  if (v.is_integer()) return "an integer";
  if (v.is_floating()) return "a float";
  if (v.is_table()) return "a table";
  if (v.is_array()) return "an array";
  return "a date or time";
}

void SetFromToml(Scene& scene, const SceneField& f, const toml::value& v) {
  auto wrong_type = [&] {
    return SceneError(std::string(f.name),
                      std::string("expected ") + TypeName(f.ref) + ", got " + TomlTypeName(v));
  };
  switch (f.ref.index()) {
    case 0:  // double: integers are accepted too ("mass_kg = 1")
    case 1:
      if (v.is_floating()) {
        if (f.ref.index() == 1) throw wrong_type();
        SetNumber(scene, f, v.as_floating(), FormatNumber(v.as_floating()));
      } else if (v.is_integer()) {
        SetNumber(scene, f, static_cast<double>(v.as_integer()), std::to_string(v.as_integer()));
      } else {
        throw wrong_type();
      }
      break;
    case 2:
      if (!v.is_boolean()) throw wrong_type();
      std::get<bool& (*)(Scene&)>(f.ref)(scene) = v.as_boolean();
      break;
    case 3:
      if (!v.is_string()) throw wrong_type();
      SetString(scene, f, v.as_string().str);
      break;
    default: {
      if (!v.is_array()) throw wrong_type();
      std::vector<double> list;
      for (const toml::value& item : v.as_array()) {
        if (item.is_floating()) {
          list.push_back(item.as_floating());
        } else if (item.is_integer()) {
          list.push_back(static_cast<double>(item.as_integer()));
        } else {
          throw wrong_type();
        }
        CheckRange(f, list.back(), FormatNumber(list.back()));
      }
      std::get<std::vector<double>& (*)(Scene&)>(f.ref)(scene) = list;
      break;
    }
  }
}

}  // namespace

std::span<const SceneField> SceneFields() {
  return FieldTable();
}

std::string_view ShapesName(Shapes shapes) {
  switch (shapes) {
    case Shapes::kSourceBed:
      return "source bed";
    case Shapes::kCutBed:
      return "cut bed";
    case Shapes::kEveryCut:
      return "every cut";
    case Shapes::kFrictionBed:
      return "friction stage";
    case Shapes::kImportedBed:
      return "imported bed";
    case Shapes::kImpact:
      return "impact";
    case Shapes::kOutput:
      return "output";
    case Shapes::kNothing:
      return "nothing";
  }
  return "nothing";
}

const SceneField* FindSceneField(std::string_view name) {
  for (const auto& f : FieldTable())
    if (f.name == name) return &f;
  return nullptr;
}

void SetSceneField(Scene& scene, std::string_view name, std::string_view value) {
  const SceneField& f = RequireSceneField(name);
  switch (f.ref.index()) {
    case 0:
    case 1: {
      double v = 0.0;
      auto [end, ec] = std::from_chars(value.data(), value.data() + value.size(), v);
      if (ec != std::errc() || end != value.data() + value.size() || value.empty())
        throw SceneError(std::string(name), "\"" + std::string(value) + "\" is not a number");
      SetNumber(scene, f, v, value);
      break;
    }
    case 2:
      if (value == "true" || value == "1") {
        std::get<bool& (*)(Scene&)>(f.ref)(scene) = true;
      } else if (value == "false" || value == "0") {
        std::get<bool& (*)(Scene&)>(f.ref)(scene) = false;
      } else {
        throw SceneError(std::string(name),
                         "\"" + std::string(value) + "\" is not a boolean; use true or false");
      }
      break;
    case 3:
      SetString(scene, f, value);
      break;
    default: {  // comma-separated numbers; empty for none
      const auto count = value.empty() ? 0 : std::count(value.begin(), value.end(), ',') + 1;
      if (static_cast<std::size_t>(count) > kSceneLimits.max_array)
        throw SceneError(std::string(name), std::to_string(count) + " values; at most " +
                                                std::to_string(kSceneLimits.max_array));
      std::vector<double> list;
      std::string_view rest = value;
      while (!rest.empty()) {
        const auto comma = rest.find(',');
        std::string_view item = rest.substr(0, comma);
        while (!item.empty() && item.front() == ' ') item.remove_prefix(1);
        while (!item.empty() && item.back() == ' ') item.remove_suffix(1);
        double v = 0.0;
        auto [end, ec] = std::from_chars(item.data(), item.data() + item.size(), v);
        if (ec != std::errc() || end != item.data() + item.size() || item.empty())
          throw SceneError(std::string(name), "\"" + std::string(item) +
                                                  "\" is not a number (give a comma-separated "
                                                  "list)");
        CheckRange(f, v, item);
        list.push_back(v);
        rest = comma == std::string_view::npos ? std::string_view() : rest.substr(comma + 1);
      }
      std::get<std::vector<double>& (*)(Scene&)>(f.ref)(scene) = list;
      break;
    }
  }
}

void ApplyOverride(Scene& scene, std::string_view assignment) {
  auto eq = assignment.find('=');
  if (eq == std::string_view::npos || eq == 0)
    throw SceneError(
        "", "override \"" + std::string(assignment) + "\" must have the form dotted.field=value");
  const std::string_view name = assignment.substr(0, eq), text = assignment.substr(eq + 1);
  if (SkipsWithdrawnField(name, text)) return;
  const SceneField& field = RequireSceneField(name);
  // The value as a scene file (and `dembuf scene --print`) writes it: [0.01, 0.02], "relax",
  // 1e-5. Text that is not a TOML value (a bare file name, 0.01,0.02) is taken as it is, and
  // so is any text for a field of text (a file named 1 is the text "1").
  std::optional<toml::value> value;
  const std::string line = "v = " + std::string(text);
  try {
    CheckTomlText(line, "--set " + std::string(name), kSceneLimits);
    std::istringstream in(line);
    value = toml::parse(in, "--set").as_table().at("v");
  } catch (const InputLimitError& e) {
    throw SceneError(std::string(name), e.what());
  } catch (const std::exception&) {
    value.reset();
  }
  const bool text_field = std::holds_alternative<std::string& (*)(Scene&)>(field.ref);
  if (value && (!text_field || value->is_string())) {
    try {
      SetFromToml(scene, field, *value);
      return;
    } catch (const SceneError& toml_error) {
      // A value the text form also takes (projectile.enabled=1) stays accepted; else the
      // TOML reading's words ("expected a number, got an array") say what is wrong.
      try {
        SetSceneField(scene, name, text);
        return;
      } catch (const SceneError&) {
        throw toml_error;
      }
    }
  }
  SetSceneField(scene, name, text);
}

namespace {

Scene SceneFromToml(const toml::value& root, const std::string& path, const Scene& base) {
  Scene scene = base;
  // Sorted, so that the first error reported does not depend on hash order.
  std::map<std::string, const toml::value*> entries;
  for (const auto& [key, value] : root.as_table()) {
    if (value.is_table()) {
      for (const auto& [sub, subvalue] : value.as_table()) entries[key + "." + sub] = &subvalue;
    } else {
      entries[key] = &value;
    }
  }
  for (const auto& [name, value] : entries) {
    if (value->is_table())
      throw SceneError(name, "unexpected nested table; " + KnownFieldsNear(name));
    if (SkipsWithdrawnField(name, value->is_boolean() ? (value->as_boolean() ? "true" : "false")
                                                      : toml::format(*value)))
      continue;
    SetFromToml(scene, RequireSceneField(name), *value);
  }
  // A relative bed file is relative to the scene file, not to wherever the run starts.
  if (!path.empty() && !scene.bed.import.empty() && entries.count("bed.import") &&
      std::filesystem::path(scene.bed.import).is_relative()) {
    scene.bed.import =
        (std::filesystem::path(path).parent_path() / scene.bed.import).lexically_normal().string();
  }
  ValidateScene(scene);
  return scene;
}

Scene LoadScene(const std::string& text, const std::string& name, const std::string& path,
                const Scene& base) {
  try {
    CheckTomlText(text, name, kSceneLimits);
  } catch (const InputLimitError& e) {
    throw SceneError("", e.what());
  }
  toml::value root;
  try {
    std::istringstream in(text);
    root = toml::parse(in, name);
  } catch (const std::exception& e) {
    throw SceneError("", name + " is not valid TOML: " + e.what());
  }
  return SceneFromToml(root, path, base);
}

}  // namespace

Scene LoadSceneFile(const std::string& path, const Scene& base) {
  std::string text;
  try {
    text = ReadBoundedFile(path, kSceneLimits.max_bytes, "scene file");
  } catch (const InputLimitError& e) {
    throw SceneError("", e.what());
  }
  Scene scene = LoadScene(text, "scene file \"" + path + "\"", path, base);
  CheckSceneFiles(scene);  // a scene file is read on the machine whose files it names
  return scene;
}

Scene LoadSceneText(const std::string& text, const std::string& name, const Scene& base) {
  return LoadScene(text, name, "", base);
}

namespace {

// Each field within its own range, or among its choices.
void CheckFieldRanges(const Scene& scene) {
  Scene copy = scene;  // the field accessors take a mutable scene
  for (const auto& f : FieldTable()) {
    if (auto* get = std::get_if<double& (*)(Scene&)>(&f.ref)) {
      double v = (*get)(copy);
      CheckRange(f, v, FormatNumber(v));
    } else if (auto* geti = std::get_if<std::int64_t& (*)(Scene&)>(&f.ref)) {
      auto v = (*geti)(copy);
      CheckRange(f, static_cast<double>(v), std::to_string(v));
    } else if (auto* gets = std::get_if<std::string& (*)(Scene&)>(&f.ref)) {
      SetString(copy, f, (*gets)(copy));  // checks the choices
    } else if (auto* getl = std::get_if<std::vector<double>& (*)(Scene&)>(&f.ref)) {
      for (double v : (*getl)(copy)) CheckRange(f, v, FormatNumber(v));
    }
  }
}

// The projectile fits in the cylinder, starts above the bed and gets there.
void CheckProjectile(const Scene& scene) {
  auto fail = [](const char* field, const std::string& why) { throw SceneError(field, why); };
  const auto& p = scene.projectile;
  if (p.enabled) {
    if (p.diameter_m >= 2.0 * scene.cylinder.radius_m)
      fail("projectile.diameter_m", FormatNumber(p.diameter_m) +
                                        " does not fit in the cylinder (inner diameter " +
                                        FormatNumber(2.0 * scene.cylinder.radius_m) + " m)");
    if (p.offset_m + 0.5 * p.diameter_m > scene.cylinder.radius_m * (1.0 + 1e-12))
      fail("projectile.offset_m",
           FormatNumber(p.offset_m) + " puts the projectile into the side wall: at most " +
               FormatNumber(scene.cylinder.radius_m - 0.5 * p.diameter_m) +
               " m (cylinder.radius_m - projectile.diameter_m / 2, which grazes the wall)");
    if (p.height_m <= 0.5 * p.diameter_m)
      fail("projectile.height_m", FormatNumber(p.height_m) +
                                      " puts the projectile into the bed: the centre must be more "
                                      "than one radius (" +
                                      FormatNumber(0.5 * p.diameter_m) + " m) above the surface");
    // The automatic end waits for the impact: the projectile must get there. (With a fixed
    // end the run may end in flight.)
    const double flight = FallTime(scene.bed.thickness_m + p.height_m, -p.speed_m_s,
                                   scene.bed.thickness_m + 0.5 * p.diameter_m, scene.gravity_m_s2);
    if (scene.time.end_s == 0.0 && flight < 0.0)
      fail("projectile.speed_m_s",
           "0 with gravity_m_s2 = 0: the projectile never reaches the bed; give it a speed or "
           "gravity, or set time.end_s");
    if (scene.time.end_s == 0.0 && !(flight <= kMaxFlightTime_s))
      fail("projectile.speed_m_s",
           FormatShort(p.speed_m_s) +
               " m/s with gravity_m_s2 = " + FormatShort(scene.gravity_m_s2) +
               ": the projectile reaches the bed after " + FormatShort(flight) + " s; at most " +
               std::to_string(static_cast<long long>(kMaxFlightTime_s)) +
               " s (raise the speed or gravity, lower projectile.height_m, or set time.end_s)");
  } else if (scene.time.end_s == 0.0) {
    fail("time.end_s",
         "0 (automatic) needs a projectile: the automatic end waits for its impact; set "
         "time.end_s > 0 when projectile.enabled = false");
  }
}

// The bed can be prepared: its loose column fits under the wall, and soft settling keeps the
// pour's overlaps small.
void CheckBedPreparation(const Scene& scene) {
  auto fail = [](const char* field, const std::string& why) { throw SceneError(field, why); };
  if (scene.bed.thickness_m > 0.0 && scene.bed.import.empty()) {
    const SourcePlan plan = PlanSourceBed(scene);
    if (plan.column_top_m > scene.cylinder.height_m)
      fail("bed.source_thickness_m",
           FormatShort(plan.thickness_m) + " m: its beads are inserted in a loose column " +
               FormatShort(plan.column_top_m) +
               " m high, above cylinder.height_m = " + FormatShort(scene.cylinder.height_m) +
               " (raise the wall, or lower bed.source_thickness_m or bed.thickness_m)");
  }
  // A step shorter than the impact's only costs time, and a tiny one would never end.
  if (scene.bed.cut_alpha > 0.0 && scene.bed.cut_alpha < scene.time.alpha)
    fail("bed.cut_alpha",
         FormatShort(scene.bed.cut_alpha) +
             ": 0 (automatic) or from time.alpha = " + FormatShort(scene.time.alpha) + " to 1");
  // With the whole bed stopped at its kinetic-energy peaks, longer steps made beds that passed
  // the rest check out of balance (a bead moved 1.4 mm when imported back). Only where a bed
  // is cut: a bare plate or an imported bed has no cut to relax.
  const bool cuts_a_bed = scene.bed.thickness_m > 0.0 && scene.bed.import.empty();
  if (cuts_a_bed && scene.bed.quench_cut_relaxation && scene.bed.cut_alpha > scene.time.alpha)
    fail("bed.cut_alpha", FormatShort(scene.bed.cut_alpha) +
                              " with bed.quench_cut_relaxation: 0 (automatic) or time.alpha = " +
                              FormatShort(scene.time.alpha) +
                              ", or bed.quench_cut_relaxation = false; a longer step made beds "
                              "out of balance (docs/accuracy-cost.md)");
  if (scene.bed.soft_settling > 0.0 && scene.bed.soft_settling < 1.0)
    fail("bed.soft_settling",
         FormatShort(scene.bed.soft_settling) + ": 0 (automatic), 1 (off) or a factor above 1");
  if (const double softening = SoftSettlingFactor(scene); softening > 1.0) {
    // Softer contacts overlap more: the pour's hardest collisions (the smallest beads, falling
    // from the top of the wall onto a bead or the plate) must stay within kMaxSoftOverlap of
    // their radius (with 100 on the paper's scene, 8.9%, on the plate).
    const double overlap = SoftPourOverlap(scene, softening);
    if (overlap > kMaxSoftOverlap)
      fail("bed.soft_settling",
           FormatShort(softening) +
               " softens the contacts so much that the settling beads would overlap by " +
               FormatShort(100.0 * overlap) + "% of their radius; at most " +
               FormatShort(100.0 * kMaxSoftOverlap) +
               "% (lower bed.soft_settling; 0 = automatic, 1 = off)");
  }
}

}  // namespace

void ValidateScene(const Scene& scene) {
  CheckFieldRanges(scene);
  auto fail = [](const char* field, const std::string& why) { throw SceneError(field, why); };
  const auto& b = scene.beads;
  if (b.diameter_min_m > b.diameter_max_m)
    fail("beads.diameter_min_m",
         FormatNumber(b.diameter_min_m) +
             " exceeds beads.diameter_max_m = " + FormatNumber(b.diameter_max_m));
  if (b.diameter_max_m >= scene.cylinder.radius_m)
    fail("beads.diameter_max_m",
         FormatNumber(b.diameter_max_m) +
             " must be smaller than cylinder.radius_m = " + FormatNumber(scene.cylinder.radius_m));
  if (scene.bed.thickness_m >= scene.cylinder.height_m)
    fail("bed.thickness_m",
         FormatNumber(scene.bed.thickness_m) +
             " must be below cylinder.height_m = " + FormatNumber(scene.cylinder.height_m));
  CheckSpeciesAndLayers(scene);
  CheckProjectile(scene);
  CheckBedPreparation(scene);
  if (const double interval = scene.output.animation_interval_s; interval > 0.0) {
    // The impact lasts until time.end_s, or at most the impact window after the first contact.
    const double impact_s = scene.time.end_s > 0.0 ? scene.time.end_s : scene.time.impact_window_s;
    if (impact_s / interval + 1 > kMaxAnimationFrames)
      fail("output.animation_interval_s",
           FormatShort(interval) + " s gives " + FormatShort(std::floor(impact_s / interval) + 1) +
               " frames over the impact's " + FormatShort(impact_s) + " s; at most " +
               FormatShort(kMaxAnimationFrames) + " (at least " +
               FormatShort(impact_s / (kMaxAnimationFrames - 1)) + " s)");
  }
}

void CheckSceneFiles(const Scene& scene) {
  if (!scene.bed.import.empty() && !scene.bed.import_bytes && !IsRegularFile(scene.bed.import))
    throw SceneError("bed.import",
                     "file \"" + scene.bed.import + "\" does not exist or is not a file");
}

std::vector<std::string> SceneWarnings(const Scene& scene) {
  std::vector<std::string> warnings;
  auto warn = [&](const char* field, const std::string& what) {
    warnings.push_back(std::string(field) + ": " + what);
  };
  const MaterialSpec& m = scene.material;
  if (m.restitution < 0.05)
    warn("material.restitution",
         FormatShort(m.restitution) +
             " is below 0.05, the lowest restitution tested: the calibrated damping then "
             "dominates every contact and the forces are not physical (1e-9 gave a 12.8 MN "
             "peak on the bare plate)");
  // No solid is lighter than cork or denser than osmium.
  auto density = [&](const char* field, double rho, const std::string& of) {
    if (rho < 100 || rho > 25000)
      warn(field, of + " would be " + FormatShort(rho) +
                      " kg/m^3; solids lie between 100 (cork) and 22,600 (osmium)");
  };
  density("material.density_kg_m3", m.density_kg_m3, "the beads' density");
  // The other species in the bed, and their pairs, by the same measures.
  for (int k = 1; k < SpeciesCount(scene); ++k) {
    if (!SpeciesInBed(scene, k)) continue;
    const SpeciesSpec& s = scene.species[k - 1];
    const std::string prefix = "species" + std::to_string(k + 1) + ".";
    if (const double rho = s.density_kg_m3; rho < 100 || rho > 25000)
      warnings.push_back(prefix + "density_kg_m3: " + FormatShort(rho) +
                         " kg/m^3; solids lie between 100 (cork) and 22,600 (osmium)");
    if (s.youngs_modulus_Pa < 1e6 || s.youngs_modulus_Pa > 1.2e12)
      warnings.push_back(prefix + "youngs_modulus_Pa: " + FormatShort(s.youngs_modulus_Pa) +
                         " Pa: solids lie between 1e6 (soft rubber) and 1.2e12 (diamond)");
    if (s.restitution < 0.05)
      warnings.push_back(prefix + "restitution: " + FormatShort(s.restitution) +
                         " is below 0.05, the lowest restitution tested");
  }
  for (const auto& [field, e, a, b] :
       {std::tuple{"pairs.restitution_1_2", scene.pairs.restitution_1_2, 0, 1},
        {"pairs.restitution_1_3", scene.pairs.restitution_1_3, 0, 2},
        {"pairs.restitution_2_3", scene.pairs.restitution_2_3, 1, 2}})
    if (SpeciesInBed(scene, a) && SpeciesInBed(scene, b) && e > 0.0 && e < 0.05)
      warn(field, FormatShort(e) + " is below 0.05, the lowest restitution tested");
  const ProjectileSpec& p = scene.projectile;
  if (p.enabled) {
    density("projectile.mass_kg",
            p.mass_kg / (std::numbers::pi / 6.0 * p.diameter_m * p.diameter_m * p.diameter_m),
            "the projectile's density");
    const double speed =
        std::sqrt(p.speed_m_s * p.speed_m_s +
                  2.0 * scene.gravity_m_s2 * std::max(p.height_m - 0.5 * p.diameter_m, 0.0));
    if (speed > 50.0)
      warn("projectile.speed_m_s",
           "the projectile hits at " + FormatShort(speed) +
               " m/s, above the 50 m/s tested; overlaps there reach 30% of a radius, far from "
               "the small strains of Hertz's law (glass would break)");
  }
  if (m.youngs_modulus_Pa < 1e6 || m.youngs_modulus_Pa > 1.2e12)
    warn("material.youngs_modulus_Pa",
         FormatShort(m.youngs_modulus_Pa) +
             " Pa: solids lie between 1e6 (soft rubber) and 1.2e12 (diamond); was it typed in "
             "another unit?");
  for (const auto& [field, mu] : {std::pair{"material.friction_bead_bead", m.friction_bead_bead},
                                  {"material.friction_bead_wall", m.friction_bead_wall}})
    if (mu > 2.0)
      warn(field, FormatShort(mu) +
                      " is above 2; dry solids have friction coefficients below about 1.5 "
                      "(glass on glass: 0.5)");
  if (scene.time.alpha > 0.6)
    warn("time.alpha", FormatShort(scene.time.alpha) +
                           " is above 0.6: the E2 impact on a dense bed became unstable at 0.8 "
                           "(docs/accuracy-cost.md)");
  if (scene.bed.cut_alpha > kLongestCheckedCutAlpha)
    warn("bed.cut_alpha", FormatShort(scene.bed.cut_alpha) + " is above " +
                              FormatShort(kLongestCheckedCutAlpha) +
                              ", the longest cut step the tests check "
                              "(docs/accuracy-cost.md)");
  if (scene.gravity_m_s2 == 0.0 && scene.bed.thickness_m > 0.0 && scene.bed.import.empty())
    warn("gravity_m_s2",
         "0 with a bed to prepare: without weight the inserted beads never settle, and the "
         "bed stays the loose column they were inserted in");
  if (scene.gravity_m_s2 > 100.0)
    warn("gravity_m_s2", FormatShort(scene.gravity_m_s2) + " m/s^2 is over ten times the Earth's");
  return warnings;
}

std::string FormatSceneField(const Scene& scene, const SceneField& field) {
  Scene& s = const_cast<Scene&>(scene);  // accessors only read here
  return std::visit(
      [&](auto get) -> std::string {
        const auto& v = get(s);
        using T = std::decay_t<decltype(v)>;
        if constexpr (std::is_same_v<T, double>) {
          return FormatNumber(v);
        } else if constexpr (std::is_same_v<T, std::int64_t>) {
          return std::to_string(v);
        } else if constexpr (std::is_same_v<T, bool>) {
          return v ? "true" : "false";
        } else if constexpr (std::is_same_v<T, std::vector<double>>) {
          std::string list = "[";
          for (std::size_t k = 0; k < v.size(); ++k) list += (k ? ", " : "") + FormatNumber(v[k]);
          return list + "]";
        } else {
          std::string quoted = "\"";
          for (char c : v) {
            if (c == '"' || c == '\\') quoted += '\\';
            quoted += c;
          }
          return quoted + "\"";
        }
      },
      field.ref);
}

void PrintScene(const Scene& scene, std::ostream& out) {
  out << "# dembuf scene: SI units; every field can be overridden with --set name=value\n";
  std::string_view section;
  for (const auto& f : FieldTable()) {
    auto dot = f.name.find('.');
    std::string_view sec = dot == std::string_view::npos ? "" : f.name.substr(0, dot);
    std::string_view key = dot == std::string_view::npos ? f.name : f.name.substr(dot + 1);
    if (sec != section) {
      out << "\n[" << sec << "]\n";
      section = sec;
    }
    out << key << " = " << FormatSceneField(scene, f) << "  # ";
    if (!f.unit.empty()) out << "[" << f.unit << "] ";
    out << f.help << "\n";
  }
}

}  // namespace dembuf
