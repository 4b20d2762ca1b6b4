#include "dembuf/study/scene/presets.h"

#include <algorithm>
#include <cctype>

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

std::string PresetSummary(const Preset& preset) {
  // The file's opening comment, its lines joined, up to the end of its first sentence: a
  // full stop, a space, then a letter ("Figs. 2-3" does not end one).
  std::string comment;
  std::string_view rest = preset.toml;
  while (rest.starts_with("#")) {
    const std::size_t end = std::min(rest.find('\n'), rest.size());
    std::string_view line = rest.substr(1, end - 1);
    if (line.starts_with(" ")) line.remove_prefix(1);
    comment += (comment.empty() ? "" : " ") + std::string(line);
    rest.remove_prefix(std::min(end + 1, rest.size()));
  }
  for (std::size_t i = 0; i + 2 < comment.size(); ++i)
    if (comment[i] == '.' && comment[i + 1] == ' ' &&
        std::isalpha(static_cast<unsigned char>(comment[i + 2])))
      return comment.substr(0, i + 1);
  return comment;
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
