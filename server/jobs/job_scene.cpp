#include "jobs/job_scene.h"

#include <cctype>
#include <optional>
#include <string>

#include "dembuf/study/scene/errors.h"
#include "dembuf/study/scene/scene_fields.h"

namespace dembuf::server {

Scene SceneOfJob(Store& store, const JobRecord& job) {
  const std::string what = "job " + std::to_string(job.id);
  if (job.bed_file.empty()) {
    Scene scene = LoadSceneText(job.scene_toml, what);
    if (!scene.bed.import.empty())
      throw SceneError("bed.import", what + " names a bed file that was not sent with it");
    return scene;
  }
  const std::optional<BedFile> file = store.GetBedFile(job.owner, job.bed_file);
  if (!file) throw SceneError("bed_file", what + ": its bed file " + job.bed_file + " is gone");
  // The bytes first: the file is not on this machine's disk, and the scene is validated.
  Scene with_bytes;
  with_bytes.bed.import_bytes = file->data;
  with_bytes.bed.import_sha256 = file->sha256;
  Scene scene = LoadSceneText(job.scene_toml, what, with_bytes);
  if (scene.bed.import != file->name || !IsPlainBedFileName(scene.bed.import))
    throw SceneError("bed.import", what + " names a bed file other than the one sent with it");
  return scene;
}

bool IsPlainBedFileName(const std::string& name) {
  if (name.empty() || name.size() > kMaxBedFileNameBytes || name.front() == '.') return false;
  for (const char c : name)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '.' && c != '_' && c != '-')
      return false;
  return true;
}

}  // namespace dembuf::server
