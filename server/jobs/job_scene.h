// What a stored job runs: its scene, read from the store as the job was admitted, with the
// bytes of the bed file it imports, and the bounds on what a job may name and write. Both
// executors read a job's scene here; the request door (doors/scene_request.h) builds scenes
// from requests, before a job exists.
#pragma once

#include <cstddef>
#include <string>

#include "dembuf/study/scene/scene.h"
#include "store/store.h"

namespace dembuf::server {

/// The most snapshots (output.snapshot_*) one job on the server may take.
inline constexpr std::size_t kMaxServerSnapshots = 100;

/// The longest name a bed file sent to the daemon may have.
inline constexpr std::size_t kMaxBedFileNameBytes = 100;
/// Whether `name` may name a bed file sent to the daemon: 1 to kMaxBedFileNameBytes of
/// [A-Za-z0-9._-], not starting with a dot (it becomes a file name on a cluster's nodes).
bool IsPlainBedFileName(const std::string& name);

/// A stored job's scene, with the bytes of the bed file it imports. Throws SceneError, or
/// DamagedData for a bed file that no longer matches its checksum. A scene that names a file
/// it did not come with is refused here too: no executor looks a path up.
Scene SceneOfJob(Store& store, const JobRecord& job);

}  // namespace dembuf::server
