// A number for a message or a name: `significant` digits, the shortest of %g's forms.
#pragma once

#include <cstdio>
#include <string>

namespace dembuf {

inline std::string NumberText(double v, int significant) {
  char text[48];
  std::snprintf(text, sizeof text, "%.*g", significant, v);
  return text;
}

}  // namespace dembuf
