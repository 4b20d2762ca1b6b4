// The engine's error types. The engine never exits or prints: it throws these, and the caller
// (the CLI, the daemon) turns them into messages or status codes.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>

namespace dembuf {

/// A scene field is missing, malformed or out of range. `field` is the dotted name.
class SceneError : public std::runtime_error {
 public:
  SceneError(std::string field, const std::string& message)
      : std::runtime_error(field.empty() ? message : field + ": " + message),
        m_field(std::move(field)) {}
  const std::string& field() const { return m_field; }

 private:
  std::string m_field;
};

/// The simulation became unstable or left its valid domain. Carries where and when.
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

/// The run was cancelled through its cancellation flag.
class Cancelled : public std::runtime_error {
 public:
  Cancelled() : std::runtime_error("cancelled") {}
};

}  // namespace dembuf
