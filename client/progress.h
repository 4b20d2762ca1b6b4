// A one-line progress display for long runs: simulated time, steps, and the time left.
#pragma once

#include <chrono>
#include <cstdio>

#include "dembuf/study/impact.h"

namespace dembuf::cli {

class ProgressLine {
 public:
  /// Draws on `out` only when it is a terminal (a pipe or a log file gets the final summary).
  explicit ProgressLine(std::FILE* out);
  void Update(const ImpactProgress& p);
  void Finish();

 private:
  std::FILE* m_out;
  bool m_enabled;
  bool m_started = false;
  double m_t0 = 0.0;
  std::chrono::steady_clock::time_point m_wall0;
  std::chrono::steady_clock::time_point m_last_draw;
};

}  // namespace dembuf::cli
