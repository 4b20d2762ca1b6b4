// libFuzzer target: the daemon's request checks. The bytes are a SubmitSweepRequest as it
// arrives on the wire; the daemon's path from it to jobs (scene resolution, server limits,
// sweep axes and expansion) must refuse bad input with a SceneError and never crash or hang.
#include <cstddef>
#include <cstdint>
#include <string>

#include "dembuf/study/scene/errors.h"
#include "dembuf/study/sweep/sweep_plan.h"
#include "dembuf/v1/dembuf.pb.h"
#include "google/protobuf/stubs/logging.h"
#include "scene_request.h"

// Protobuf logs every string that is not UTF-8 (and refuses the message): silence it.
extern "C" int LLVMFuzzerInitialize(int*, char***) {
  google::protobuf::SetLogHandler(nullptr);
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  dembuf::v1::SubmitSweepRequest request;
  if (!request.ParseFromArray(data, static_cast<int>(size))) return 0;
  try {
    dembuf::server::CheckSweepAxes(request);
    const dembuf::Scene base = dembuf::server::ResolveSceneSpec(request.base());
    dembuf::server::CheckServerScene(base);
    std::vector<dembuf::SweepAxis> axes;
    for (const auto& axis : request.axes()) {
      const std::vector<std::string> values(axis.values().begin(), axis.values().end());
      axes.push_back(dembuf::MakeSweepAxis(axis.field(), values, axis.range()));
    }
    const int seeds = request.seeds() < 1 ? 1 : request.seeds();
    axes = dembuf::WithSeedAxis(axes, seeds, base.bed.seed);
    // A small limit keeps each input fast; the limit itself is what is being exercised.
    for (const auto& run : dembuf::ExpandSweep(base, axes, 64))
      dembuf::server::CheckServerScene(run.scene);
  } catch (const dembuf::SceneError& e) {
    if (std::string(e.what()).empty()) __builtin_trap();
  }
  return 0;
}
