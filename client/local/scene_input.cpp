#include "local/scene_input.h"

#include "dembuf/study/scene/presets.h"
#include "dembuf/study/scene/scene_fields.h"

namespace dembuf::cli {

Scene ResolveScene(const std::string& scene_file, const std::string& preset,
                   const std::vector<std::string>& overrides, const std::string& accuracy) {
  Scene scene = preset.empty() ? Scene{} : PresetScene(preset);
  if (!scene_file.empty()) scene = LoadSceneFile(scene_file, scene);
  if (!accuracy.empty()) ApplyAccuracy(scene, accuracy);
  for (const auto& assignment : overrides) ApplyOverride(scene, assignment);
  ValidateScene(scene);
  CheckSceneFiles(scene);
  return scene;
}

}  // namespace dembuf::cli
