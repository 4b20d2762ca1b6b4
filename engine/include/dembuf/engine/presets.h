// The paper's experiments E1-E5 as named scenes (the files of scenes/, compiled in).
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "dembuf/engine/scene.h"

namespace dembuf {

struct Preset {
  std::string_view name;
  std::string_view toml;
};

const std::vector<Preset>& Presets();

/// The preset's scene (defaults, then the preset's fields). Throws SceneError naming
/// "--preset" and the known names for an unknown one.
Scene PresetScene(const std::string& name);

}  // namespace dembuf
