// The core's error type. The engine never exits or prints: it throws, and the caller (the
// CLI, the daemon) turns what it throws into messages or status codes.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>

namespace dembuf::dem {

/// The simulation became unstable or left its valid domain (non-finite values, an overlap too
/// deep, a bead outside the container). Carries where and when; the message says what to change.
class SimulationError : public std::runtime_error {
 public:
  SimulationError(const std::string& message, std::int64_t step, double time_s)
      : std::runtime_error(message), m_step(step), m_time_s(time_s) {}
  std::int64_t step() const { return m_step; }
  double time_s() const { return m_time_s; }

 private:
  std::int64_t m_step;
  double m_time_s;
};

}  // namespace dembuf::dem
