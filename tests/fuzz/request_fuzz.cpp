// libFuzzer target: the daemon's admission. The bytes are a SubmitSweepRequest as it arrives
// on the wire; the daemon's path from it to jobs (AdmitSweep: scene resolution, sweep axes and
// expansion, every run admitted) must refuse bad input with a SceneError or ResourceError and
// never crash or hang.
#include <cstddef>
#include <cstdint>
#include <string>

#include "dembuf/study/scene/errors.h"
#include "dembuf/v1/dembuf.pb.h"
#include "doors/admission.h"
#include "google/protobuf/stubs/logging.h"

// Protobuf logs every string that is not UTF-8 (and refuses the message): silence it.
extern "C" int LLVMFuzzerInitialize(int*, char***) {
  google::protobuf::SetLogHandler(nullptr);
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  dembuf::v1::SubmitSweepRequest request;
  if (!request.ParseFromArray(data, static_cast<int>(size))) return 0;
  try {
    // A small limit keeps each input fast; the limit itself is what is being exercised.
    dembuf::server::AdmitSweep(
        request, [] { return std::optional<dembuf::server::BedFile>(); }, dembuf::ResourceLimits{},
        64);
  } catch (const dembuf::SceneError& e) {
    if (std::string(e.what()).empty()) __builtin_trap();
  } catch (const dembuf::ResourceError& e) {
    if (std::string(e.what()).empty()) __builtin_trap();
  }
  return 0;
}
