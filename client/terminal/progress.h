// Progress of long runs: simulated time, steps, rate and the time left. On a terminal one line
// redrawn in place; to a pipe or a log file (nohup, a batch system) plain lines every few
// seconds, so that a log shows a run is alive and how far it is.
#pragma once

#include <chrono>
#include <cstdio>

#include "dembuf/study/bed/bed.h"
#include "dembuf/study/impact/impact.h"

namespace dembuf::cli {

/// How much the command says besides its results (-q, -v).
enum class Verbosity { kQuiet, kNormal, kVerbose };
void SetVerbosity(Verbosity verbosity);
Verbosity GetVerbosity();

/// Seconds between plain progress lines when the output is not a terminal: DEMBUF_PROGRESS_S
/// (0.1 to 3600), else 1 with -v and 5 without.
double PlainProgressInterval();

class ProgressLine {
 public:
  explicit ProgressLine(std::FILE* out);
  void Update(const ImpactProgress& p);
  /// Ends the line on a terminal; in a log, a last line with the steps and their rate.
  void Finish();

 private:
  std::FILE* m_out;
  bool m_terminal;
  bool m_enabled;  ///< not with -q
  std::chrono::duration<double> m_interval;
  bool m_started = false;
  double m_t0 = 0.0;
  ImpactProgress m_last{};
  std::chrono::steady_clock::time_point m_wall0;
  std::chrono::steady_clock::time_point m_last_draw;
};

/// A bed's preparation: the stage, its beads, simulated time and how near rest it is; redrawn
/// on a terminal, plain lines every few seconds otherwise.
class BedProgressLine {
 public:
  explicit BedProgressLine(std::FILE* out);
  void Update(const BedProgress& p);
  /// Whether a line is left open on the terminal (to end it before other output).
  bool open() const { return m_open; }

 private:
  std::FILE* m_out;
  bool m_terminal;
  bool m_enabled;  ///< not with -q
  bool m_open = false;
  std::chrono::duration<double> m_interval;
  std::chrono::steady_clock::time_point m_last_draw;
};

}  // namespace dembuf::cli
