// From a request's SceneSpec to a validated Scene, and what the daemon refuses to run.
#pragma once

#include "dembuf/engine/scene.h"
#include "dembuf/v1/dembuf.pb.h"

namespace dembuf::server {

/// The default scene, then the preset, the scene file text, the accuracy level, the typed
/// fields, and each `set` assignment, in that order; validated. Throws SceneError naming the field
/// at fault.
Scene ResolveSceneSpec(const v1::SceneSpec& spec);

/// Applies the fields present in a proto Scene to `scene` (no validation).
void ApplyProtoScene(const v1::Scene& fields, Scene& scene);

/// Refuses what a shared daemon does not run: beds read from files on the server and
/// snapshots (written by local runs only). What a job costs is checked against the server's
/// limits separately (ServiceInfo::job_limits). Throws SceneError.
void CheckServerScene(const Scene& scene);

}  // namespace dembuf::server
