// From a request's SceneSpec to a Scene (its fields' values checked as they are set), and the
// limits on a request's size; what the daemon runs is decided by AdmitScene (admission.h).
#pragma once

#include <cstddef>
#include <optional>
#include <string>

#include "dembuf/study/scene/scene.h"
#include "dembuf/v1/dembuf.pb.h"
#include "store/records.h"

namespace dembuf::server {

/// The most assignments (`set`) one scene may carry, axes one sweep, values one axis.
inline constexpr int kMaxAssignments = 1000;
inline constexpr int kMaxAxes = 16;
inline constexpr int kMaxAxisValues = 10000;
/// The default scene, then the preset, the scene file text, the accuracy level, the typed
/// fields, and each `set` assignment, in that order. Throws SceneError naming the field at
/// fault in any of them; the scene as a whole is checked by AdmitScene. `bed_file` is the bed file
/// the spec names (SceneSpec.bed_file), found by the caller: the scene imports it, under its name,
/// from its bytes. What the daemon accepts is decided later, by AdmitScene (admission.h), on the
/// scene as it will run.
Scene ResolveSceneSpec(const v1::SceneSpec& spec,
                       const std::optional<BedFile>& bed_file = std::nullopt);

/// Applies the fields present in a proto Scene to `scene` (no validation).
void ApplyProtoScene(const v1::Scene& fields, Scene& scene);

/// Refuses a sweep with more axes, or an axis with more values, than the limits above.
/// Throws SceneError naming the axis.
void CheckSweepAxes(const v1::SubmitSweepRequest& request);

}  // namespace dembuf::server
