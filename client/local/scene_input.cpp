#include "local/scene_input.h"

#include "dembuf/study/scene/errors.h"
#include "dembuf/study/scene/presets.h"
#include "dembuf/study/scene/scene_fields.h"

namespace dembuf::cli {

void RequireJoinedAssignments(const std::string& option,
                              const std::vector<std::string>& assignments,
                              const std::string& scene_file) {
  for (const std::string& assignment : assignments) {
    if (assignment.find('=') != std::string::npos) continue;
    // `--set bed.thickness_m 0.01`: the shell gave the value as a separate word, which the
    // command took for the scene file.
    const std::string value = scene_file.empty() ? "VALUE" : scene_file;
    throw SceneError(option, "\"" + assignment +
                                 "\" has no \"=\": a field and its value are one "
                                 "word, as in " +
                                 option + " " + assignment + "=" + value);
  }
}

Scene ResolveScene(const std::string& scene_file, const std::string& preset,
                   const std::vector<std::string>& overrides, const std::string& accuracy) {
  RequireJoinedAssignments("--set", overrides, scene_file);
  Scene scene = preset.empty() ? Scene{} : PresetScene(preset);
  if (!scene_file.empty()) scene = LoadSceneFile(scene_file, scene);
  if (!accuracy.empty()) ApplyAccuracy(scene, accuracy);
  for (const auto& assignment : overrides) ApplyOverride(scene, assignment);
  ValidateScene(scene);
  CheckSceneFiles(scene);
  return scene;
}

}  // namespace dembuf::cli
