#include "dembuf/engine/presets.h"

#include "dembuf/engine/errors.h"
#include "dembuf/engine/scene_fields.h"

namespace dembuf {

Scene PresetScene(const std::string& name) {
  std::string known;
  for (const Preset& p : Presets()) {
    if (p.name == name) return LoadSceneText(std::string(p.toml), "preset " + name);
    known += (known.empty() ? "" : ", ") + std::string(p.name);
  }
  throw SceneError("preset", "unknown preset \"" + name + "\"; known presets: " + known);
}

}  // namespace dembuf
