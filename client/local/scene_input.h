// How the CLI turns its arguments (a scene file, --set overrides) into a validated Scene.
#pragma once

#include <string>
#include <vector>

#include "dembuf/study/scene/scene.h"

namespace dembuf::cli {

/// Default scene, then the preset (if any), then the file (if any), then the accuracy level
/// (if any), then each override in order; validated, and the files it names found.
Scene ResolveScene(const std::string& scene_file, const std::string& preset,
                   const std::vector<std::string>& overrides, const std::string& accuracy = "");

}  // namespace dembuf::cli
