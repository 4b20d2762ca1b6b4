// libFuzzer target: scene files. Any text must either load into a scene that passes
// validation or be refused with a SceneError naming a field or the file; anything else (a
// crash, another exception, a hang, a sanitizer report) is a bug.
#include <cstddef>
#include <cstdint>
#include <string>

#include "dembuf/study/scene/errors.h"
#include "dembuf/study/scene/scene_fields.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const dembuf::Scene scene = dembuf::LoadSceneText(text, "fuzz");
    dembuf::ValidateScene(scene);  // what loaded must be valid
  } catch (const dembuf::SceneError& e) {
    if (std::string(e.what()).empty()) __builtin_trap();  // every refusal says why
  }
  return 0;
}
