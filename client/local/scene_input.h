// How the CLI turns its arguments (a scene file, --set overrides) into a validated Scene.
#pragma once

#include <string>
#include <vector>

#include "dembuf/study/scene/scene.h"

namespace dembuf::cli {

/// Refuses an assignment (of --set or --vary) without "=": `--set bed.thickness_m 0.01` gives the
/// value as a word of its own, which the command takes for its scene file. The error names the
/// joined form, with that word as the value.
void RequireJoinedAssignments(const std::string& option,
                              const std::vector<std::string>& assignments,
                              const std::string& scene_file);

/// Default scene, then the preset (if any), then the file (if any), then the accuracy level
/// (if any), then each override in order; validated, and the files it names found.
Scene ResolveScene(const std::string& scene_file, const std::string& preset,
                   const std::vector<std::string>& overrides, const std::string& accuracy = "");

}  // namespace dembuf::cli
