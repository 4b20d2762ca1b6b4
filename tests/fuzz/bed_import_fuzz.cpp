// libFuzzer target: imported bed files (bed.import). Any text must either give a bed whose
// beads lie in the container with overlaps of at most kMaxRestingOverlap, or be refused with a
// SceneError naming bed.import; anything else (a crash, another exception, a hang, a
// sanitizer report) is a bug. Both ways of treating overlaps are fuzzed.
#include <cstddef>
#include <cstdint>
#include <sstream>
#include <string>

#include "dembuf/study/bed/bed_io.h"
#include "dembuf/study/scene/errors.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  dembuf::Scene scene;
  scene.cylinder.radius_m = 0.02;
  for (const char* overlaps : {"refuse", "relax"}) {
    scene.bed.import_overlaps = overlaps;
    std::istringstream in(text);
    try {
      const dembuf::ImportedBed bed = dembuf::ParseTextBed(in, "fuzz.txt", scene);
      if (bed.beads.size() == 0 || bed.pairs.max_ratio > dembuf::kMaxRestingOverlap ||
          bed.plate.max_ratio > dembuf::kMaxRestingOverlap ||
          bed.wall.max_ratio > dembuf::kMaxRestingOverlap)
        __builtin_trap();  // accepted what it must refuse
    } catch (const dembuf::SceneError& e) {
      if (e.field() != "bed.import") __builtin_trap();
    }
  }
  return 0;
}
