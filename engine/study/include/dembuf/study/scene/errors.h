// The study layer's error types, beside the core's SimulationError. Like the core, the study
// layer never exits or prints: it throws these, and the caller (the CLI, the daemon) turns
// them into messages or status codes.
#pragma once

#include <stdexcept>
#include <string>

#include "dembuf/core/errors.h"

namespace dembuf {

/// A scene field is missing, malformed or out of range. `field` is the dotted name. The
/// message quotes what it was given; control bytes in it (newlines and tabs apart) are
/// written as \xNN, so that the message prints whole (a NUL would end it) wherever it goes.
class SceneError : public std::runtime_error {
 public:
  SceneError(std::string field, const std::string& message)
      : std::runtime_error(Printable(field.empty() ? message : field + ": " + message)),
        m_field(std::move(field)) {}
  const std::string& field() const { return m_field; }

 private:
  static std::string Printable(const std::string& text) {
    static const char* const kHex = "0123456789abcdef";
    std::string out;
    for (unsigned char c : text) {
      if ((c < 0x20 && c != '\n' && c != '\t') || c == 0x7f) {
        out += "\\x";
        out += kHex[c >> 4];
        out += kHex[c & 0xf];
      } else {
        out += static_cast<char>(c);
      }
    }
    return out;
  }

  std::string m_field;
};

/// The run was cancelled through its cancellation flag.
class Cancelled : public std::runtime_error {
 public:
  Cancelled() : std::runtime_error("cancelled") {}
};

}  // namespace dembuf
