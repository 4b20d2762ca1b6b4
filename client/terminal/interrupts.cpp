#include "terminal/interrupts.h"

#include <csignal>

namespace dembuf::cli {

namespace {

std::atomic<bool> g_interrupted{false};
std::atomic<int> g_signal{0};

extern "C" void OnInterrupt(int signal) {
  g_signal.store(signal);
  g_interrupted.store(true);
}

}  // namespace

const std::atomic<bool>& Interrupted() {
  return g_interrupted;
}

void CatchInterrupts() {
  std::signal(SIGINT, OnInterrupt);
  std::signal(SIGTERM, OnInterrupt);
}

int InterruptedExit() {
  const int signal = g_signal.load();
  return 128 + (signal ? signal : SIGINT);
}

const char* InterruptName() {
  return g_signal.load() == SIGTERM ? "SIGTERM" : "SIGINT";
}

}  // namespace dembuf::cli
