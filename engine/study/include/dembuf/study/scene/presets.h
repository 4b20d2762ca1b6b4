// The paper's experiments E1-E5 as named scenes (the files of scenes/, compiled in).
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "dembuf/study/scene/scene.h"

namespace dembuf {

struct Preset {
  std::string_view name;
  std::string_view toml;
};

const std::vector<Preset>& Presets();

/// What a preset is, in one sentence: the first of its file's opening comment (scenes/*.toml),
/// so that the file stays the one place that says it.
std::string PresetSummary(const Preset& preset);

/// The preset's scene (defaults, then the preset's fields). Throws SceneError naming
/// "--preset" and the known names for an unknown one.
Scene PresetScene(const std::string& name);

/// A named accuracy level: the accuracy knobs (time step, settling tolerance) set together.
/// Their measured error and cost are in docs/accuracy-cost.md.
struct AccuracyPreset {
  std::string_view name;
  std::string_view description;
  double alpha;                ///< time.alpha
  double settle_tolerance;     ///< bed.settle_tolerance
  bool quench_cut_relaxation;  ///< bed.quench_cut_relaxation
};

/// draft, standard (the defaults) and reference.
const std::vector<AccuracyPreset>& AccuracyPresets();

/// Sets the preset's fields. Throws SceneError("accuracy", ...) for an unknown name.
void ApplyAccuracy(Scene& scene, const std::string& name);

}  // namespace dembuf
