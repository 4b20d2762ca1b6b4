#include "dembuf/study/scene/presets.h"

#include "dembuf/study/scene/errors.h"
#include "dembuf/study/scene/scene_fields.h"

namespace dembuf {

Scene PresetScene(const std::string& name) {
  std::string known;
  for (const Preset& p : Presets()) {
    if (p.name == name) return LoadSceneText(std::string(p.toml), "preset " + name);
    known += (known.empty() ? "" : ", ") + std::string(p.name);
  }
  throw SceneError("preset", "unknown preset \"" + name + "\"; known presets: " + known);
}

const std::vector<AccuracyPreset>& AccuracyPresets() {
  static const std::vector<AccuracyPreset> presets = {
      {"draft", "quick looks: twice the time step, a looser rest reached by kinetic damping", 0.4,
       1e-4, true},
      {"standard", "the defaults: errors of a few tenths of a percent", 0.2, 1e-5, false},
      {"reference", "converged values for checking the others", 0.05, 1e-6, false},
  };
  return presets;
}

void ApplyAccuracy(Scene& scene, const std::string& name) {
  std::string known;
  for (const AccuracyPreset& p : AccuracyPresets()) {
    if (p.name == name) {
      scene.time.alpha = p.alpha;
      scene.bed.settle_tolerance = p.settle_tolerance;
      scene.bed.quench_cut_relaxation = p.quench_cut_relaxation;
      return;
    }
    known += (known.empty() ? "" : ", ") + std::string(p.name);
  }
  throw SceneError("accuracy", "unknown accuracy \"" + name + "\"; known: " + known);
}

}  // namespace dembuf
