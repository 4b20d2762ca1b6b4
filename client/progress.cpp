#include "progress.h"

#include <unistd.h>
#include <algorithm>
#include <cmath>
#include <string>

namespace dembuf::cli {

ProgressLine::ProgressLine(std::FILE* out) : m_out(out), m_enabled(isatty(fileno(out)) != 0) {}

void ProgressLine::Update(const ImpactProgress& p) {
  if (!m_enabled) return;
  const auto now = std::chrono::steady_clock::now();
  if (!m_started) {
    m_started = true;
    m_t0 = p.t_s;
    m_wall0 = now;
  }
  if (now - m_last_draw < std::chrono::milliseconds(200) && p.t_s < p.t_end_estimate_s) return;
  m_last_draw = now;

  const double span = p.t_end_estimate_s - m_t0;
  const double fraction = span > 0.0 ? std::clamp((p.t_s - m_t0) / span, 0.0, 1.0) : 1.0;
  constexpr int kWidth = 30;
  const int filled = static_cast<int>(fraction * kWidth);
  std::string bar(filled, '=');
  bar.resize(kWidth, ' ');

  // Time left from the simulated-time rate so far; the automatic end is an upper bound.
  const double wall = std::chrono::duration<double>(now - m_wall0).count();
  std::string eta = "--:--";
  if (fraction > 0.0 && wall > 0.5) {
    const long left = std::lround(wall * (1.0 - fraction) / fraction);
    char buf[32];
    std::snprintf(buf, sizeof buf, "%ld:%02ld", left / 60, left % 60);
    eta = buf;
  }
  std::fprintf(m_out, "\r[%s] %6.2f / %.2f ms  %lld steps  ETA %s (at most) ", bar.c_str(),
               p.t_s * 1e3, p.t_end_estimate_s * 1e3, static_cast<long long>(p.steps), eta.c_str());
  std::fflush(m_out);
}

void ProgressLine::Finish() {
  if (m_enabled && m_started) std::fprintf(m_out, "\n");
}

}  // namespace dembuf::cli
