// libFuzzer target: the daemon's configuration file. Any text must either give settings that
// pass validation or be refused with a ConfigError that says why; anything else (a crash,
// another exception, a hang, a sanitizer report) is a bug.
#include <cstddef>
#include <cstdint>
#include <string>

#include "process/config.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  dembuf::server::ServerConfig config;
  try {
    dembuf::server::LoadConfigText(text, "fuzz.toml", config);
    dembuf::server::ValidateConfig(config);
  } catch (const dembuf::server::ConfigError& e) {
    if (std::string(e.what()).empty()) __builtin_trap();  // every refusal says why
  }
  return 0;
}
