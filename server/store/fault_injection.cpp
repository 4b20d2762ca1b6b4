#include "store/fault_injection.h"

#include <atomic>
#include <csignal>
#include <cstdlib>
#include <string>

#include "store/sqlite.h"

namespace dembuf::server {

namespace {

// DEMBUFD_FAULT as "NAME" or "NAME:N".
struct Armed {
  std::string point;
  long times = -1;  // -1: every time
};

const Armed& ArmedFault() {
  static const Armed armed = [] {
    const char* value = std::getenv("DEMBUFD_FAULT");
    Armed a{value ? value : ""};
    if (const auto colon = a.point.find(':'); colon != std::string::npos) {
      a.times = std::strtol(a.point.c_str() + colon + 1, nullptr, 10);
      a.point.resize(colon);
    }
    return a;
  }();
  return armed;
}

}  // namespace

void FaultPoint(const char* point) {
  if (!ArmedFault().point.empty() && ArmedFault().point == point) std::raise(SIGKILL);
}

void FaultError(const char* point) {
  static std::atomic<long> passes{0};
  const Armed& armed = ArmedFault();
  if (armed.point.empty() || armed.point != point) return;
  if (armed.times >= 0 && passes.fetch_add(1) >= armed.times) return;
  throw SqliteError(std::string("injected fault at ") + point);
}

}  // namespace dembuf::server
