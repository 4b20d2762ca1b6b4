#include "scene_input.h"

#include "dembuf/engine/scene_fields.h"

namespace dembuf::cli {

Scene ResolveScene(const std::string& scene_file, const std::vector<std::string>& overrides) {
  Scene scene = scene_file.empty() ? Scene{} : LoadSceneFile(scene_file);
  for (const auto& assignment : overrides) ApplyOverride(scene, assignment);
  ValidateScene(scene);
  return scene;
}

}  // namespace dembuf::cli
