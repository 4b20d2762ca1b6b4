// The table of scene fields: one entry per dotted name, with its unit, help text, allowed
// range and what it shapes. Scene files, `--set` overrides, `scene --print`, validation and
// the bed cache keys go through it. A field's value lives in Scene and its wire form in the
// API's Scene message; tests check that every row of the table reaches both and back.
#pragma once

#include <cstdint>
#include <functional>
#include <iosfwd>
#include <span>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "dembuf/study/scene/scene.h"

namespace dembuf {

/// What a field's value shapes: the earliest stage of a run it enters (each stage carries on
/// into those after it). The cache keys of beds are computed from this column (BedKeys, bed.h):
/// a field that shapes a bed cannot be left out of its key.
enum class Shapes {
  kSourceBed,    ///< the settled source bed, so every bed cut from it
  kCutBed,       ///< the bed cut to H
  kEveryCut,     ///< every cut: the bed cut to H, and in a bed of layers the cuts between
                 ///< them, so also its source bed
  kFrictionBed,  ///< the bed after the change of friction (and a relaxed imported bed)
  kImportedBed,  ///< an imported bed (its file by content)
  kImpact,       ///< the impact only
  kOutput,       ///< what a run writes, not what it computes
  kNothing,      ///< neither: a limit a run fails past (a bed not at rest by bed.max_settle_s)
};

/// The column's value as a word ("source bed", "impact", ...).
std::string_view ShapesName(Shapes shapes);

/// One scene field. `ref` gives access to the member inside a Scene.
struct SceneField {
  using Ref = std::variant<double& (*)(Scene&), std::int64_t& (*)(Scene&), bool& (*)(Scene&),
                           std::string& (*)(Scene&), std::vector<double>& (*)(Scene&)>;
  std::string_view name;       ///< dotted name, e.g. "projectile.mass_kg"
  std::string_view unit = {};  ///< SI unit, "" when dimensionless
  std::string_view help;
  Shapes shapes;  ///< what its value shapes (no default: every field says)
  Ref ref;
  double min = 0.0;  ///< numeric range (of each element of a list); inclusive unless *_open
  double max = 0.0;
  bool min_open = false;
  bool max_open = false;
  std::vector<std::string_view> choices = {};  ///< allowed values of a string field, if restricted
  /// Whether the field acts in a scene (nullptr: in every scene). One that does not (a species
  /// no layer mixes in) is left out of the bed keys: adding such a field leaves every bed's
  /// key as it was.
  bool (*in_use)(const Scene&) = nullptr;
};

/// All fields in display order.
std::span<const SceneField> SceneFields();

/// The field of that dotted name, or nullptr.
const SceneField* FindSceneField(std::string_view name);

/// The field of that dotted name; throws SceneError naming the closest known fields.
const SceneField& RequireSceneField(std::string_view name);

/// Sets one field from text (as given to `--set name=value`). Throws SceneError naming the
/// field when the name is unknown or the value does not parse or is out of range.
void SetSceneField(Scene& scene, std::string_view name, std::string_view value);

/// Parses "name=value" and applies it with SetSceneField.
void ApplyOverride(Scene& scene, std::string_view assignment);

/// Reads a TOML scene file on top of `base` (fields absent from the file keep their value).
/// Unknown tables or keys, wrong types, out-of-range values and a bed file that is not there
/// (CheckSceneFiles) throw SceneError.
Scene LoadSceneFile(const std::string& path, const Scene& base = Scene{});

/// The same for TOML text; `name` is used in messages (e.g. "preset e2"). It looks up no file.
Scene LoadSceneText(const std::string& text, const std::string& name, const Scene& base = Scene{});

/// Checks every field's range and the relations between fields. Throws SceneError. Reads
/// nothing from the disk: a scene that names a file is checked for it by CheckSceneFiles.
void ValidateScene(const Scene& scene);

/// Checks that the files a scene names are there: its bed file (bed.import), unless its bytes
/// came with it. Throws SceneError naming the field. The local commands ask this; the daemon,
/// which reads no file a request names, never does.
void CheckSceneFiles(const Scene& scene);

/// Legal values that are physically absurd, or beyond what has been tested to give sound
/// results, as "field: what is absurd and why" (empty for an ordinary scene). Such a scene
/// runs; the callers show the warnings and keep them with the results.
std::vector<std::string> SceneWarnings(const Scene& scene);

/// Writes the complete scene as TOML, each field with its unit and help as a comment.
void PrintScene(const Scene& scene, std::ostream& out);

/// The value of a field as text (as PrintScene writes it).
std::string FormatSceneField(const Scene& scene, const SceneField& field);

}  // namespace dembuf
