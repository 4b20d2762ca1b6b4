#include "thread_shares.h"

#include <algorithm>

namespace dembuf::dem::detail {

void ThreadShares::Update(int team) {
  // Each update moves a share a quarter of the way to the measured speed: one pass's timing
  // scatters by several percent, a core's speed changes over many passes.
  constexpr double kSmoothing = 0.25;
  // No share falls much below a fifth of an equal one (the floor applies before the shares
  // are scaled to sum to 1), so that every thread keeps measuring.
  constexpr double kMinShare = 0.2;

  double total_speed = 0.0;
  bool measured = team >= 2;
  for (int t = 0; t < team && measured; ++t) {
    const Measured& m = m_measured[t];
    measured = m.work > 0.0 && m.seconds > 0.0;
    if (measured) total_speed += m.work / m.seconds;
  }
  if (measured) {
    if (m_start.size() != static_cast<std::size_t>(team) + 1) {
      m_start.resize(team + 1);
      for (int t = 0; t <= team; ++t) m_start[t] = static_cast<double>(t) / team;
    }
    // The new widths, summed into m_start[t + 1], then scaled to end at 1.
    double old_start = 0.0, sum = 0.0;
    for (int t = 0; t < team; ++t) {
      const double old_width = m_start[t + 1] - old_start;
      old_start = m_start[t + 1];
      const double speed_share = m_measured[t].work / m_measured[t].seconds / total_speed;
      sum += std::max(old_width + kSmoothing * (speed_share - old_width), kMinShare / team);
      m_start[t + 1] = sum;
    }
    for (int t = 1; t < team; ++t) m_start[t] /= sum;
    m_start[team] = 1.0;  // exactly: the last share ends at the last bead
  }
  std::fill(m_measured.begin(), m_measured.end(), Measured{});
}

}  // namespace dembuf::dem::detail
