#include "terminal/progress.h"

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdlib>
#include <string>

namespace dembuf::cli {

namespace {
std::atomic<Verbosity> g_verbosity{Verbosity::kNormal};
}  // namespace

void SetVerbosity(Verbosity verbosity) {
  g_verbosity = verbosity;
}
Verbosity GetVerbosity() {
  return g_verbosity;
}

double PlainProgressInterval() {
  if (const char* text = std::getenv("DEMBUF_PROGRESS_S"); text && *text) {
    char* end = nullptr;
    const double seconds = std::strtod(text, &end);
    if (end && *end == '\0' && seconds >= 0.1 && seconds <= 3600.0) return seconds;
    std::fprintf(stderr, "dembuf: warning: DEMBUF_PROGRESS_S=%s is not 0.1 to 3600 seconds\n",
                 text);
  }
  return GetVerbosity() == Verbosity::kVerbose ? 1.0 : 5.0;
}

namespace {

// "m:ss" of a whole number of seconds.
std::string Clock(double seconds) {
  const long s = std::lround(seconds);
  char buf[32];
  std::snprintf(buf, sizeof buf, "%ld:%02ld", s / 60, s % 60);
  return buf;
}

}  // namespace

ProgressLine::ProgressLine(std::FILE* out)
    : m_out(out),
      m_terminal(isatty(fileno(out)) != 0),
      m_enabled(GetVerbosity() != Verbosity::kQuiet),
      m_interval(m_terminal ? 0.2 : PlainProgressInterval()) {}

void ProgressLine::Update(const ImpactProgress& p) {
  if (!m_enabled) return;
  const auto now = std::chrono::steady_clock::now();
  m_last = p;
  if (!m_started) {
    m_started = true;
    m_t0 = p.t_s;
    m_wall0 = now;
    m_last_draw = now;
    if (!m_terminal) return;  // the first plain line after an interval, with a rate
  }
  if (now - m_last_draw < m_interval && p.t_s < p.t_end_estimate_s) return;
  m_last_draw = now;

  const double span = p.t_end_estimate_s - m_t0;
  const double fraction = span > 0.0 ? std::clamp((p.t_s - m_t0) / span, 0.0, 1.0) : 1.0;
  // Time left from the simulated-time rate so far; the automatic end is an upper bound.
  const double wall = std::chrono::duration<double>(now - m_wall0).count();
  const std::string eta = fraction >= 1.0                ? Clock(0.0)
                          : fraction > 0.0 && wall > 0.5 ? Clock(wall * (1.0 - fraction) / fraction)
                                                         : "--:--";
  if (m_terminal) {
    constexpr int kWidth = 30;
    std::string bar(static_cast<std::size_t>(fraction * kWidth), '=');
    bar.resize(kWidth, ' ');
    std::fprintf(m_out, "\r[%s] %6.2f / %.2f ms  %lld steps  ETA %s (at most) ", bar.c_str(),
                 p.t_s * 1e3, p.t_end_estimate_s * 1e3, static_cast<long long>(p.steps),
                 eta.c_str());
  } else {
    const double rate = wall > 0.0 ? static_cast<double>(p.steps) / wall : 0.0;
    std::fprintf(m_out,
                 "impact: %3.0f%%, %.2f of %.2f ms (at most), %lld steps, %.3g steps/s, "
                 "%s left (at most)\n",
                 100 * fraction, p.t_s * 1e3, p.t_end_estimate_s * 1e3,
                 static_cast<long long>(p.steps), rate, eta.c_str());
  }
  std::fflush(m_out);
}

void ProgressLine::Finish() {
  if (!m_enabled || !m_started) return;
  if (m_terminal) {
    std::fprintf(m_out, "\n");
    return;
  }
  const double wall =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - m_wall0).count();
  std::fprintf(m_out, "impact: ended at %.2f ms, %lld steps in %s\n", m_last.t_s * 1e3,
               static_cast<long long>(m_last.steps), Clock(wall).c_str());
  std::fflush(m_out);
}

BedProgressLine::BedProgressLine(std::FILE* out)
    : m_out(out),
      m_terminal(isatty(fileno(out)) != 0),
      m_enabled(GetVerbosity() != Verbosity::kQuiet),
      m_interval(m_terminal ? 0.0 : PlainProgressInterval()),
      m_last_draw(std::chrono::steady_clock::now()) {}

void BedProgressLine::Update(const BedProgress& p) {
  if (!m_enabled) return;
  const auto now = std::chrono::steady_clock::now();
  if (now - m_last_draw < m_interval) return;
  m_last_draw = now;
  std::fprintf(m_out, "%s%s: %zu beads, t = %.1f ms, kinetic %.2g m g d, balance %.2g%%%s",
               m_terminal ? "\r" : "", p.stage.c_str(), p.beads, p.t_s * 1e3, p.kinetic_ratio,
               p.balance_error * 100, m_terminal ? "   " : "\n");
  m_open = m_terminal;
  std::fflush(m_out);
}

}  // namespace dembuf::cli
