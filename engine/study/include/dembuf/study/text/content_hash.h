// Content hashes: 16 hex digits of FNV-1a 64 over a canonical text. They name beds and scenes;
// they detect changes, they are not a defence against deliberate collisions.
#pragma once

#include <cstdint>
#include <cstdio>
#include <string>
#include <string_view>

namespace dembuf {

inline std::string ContentHash(std::string_view text) {
  std::uint64_t h = 0xcbf29ce484222325ULL;
  for (unsigned char c : text) {
    h ^= c;
    h *= 0x100000001b3ULL;
  }
  char hex[17];
  std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(h));
  return hex;
}

}  // namespace dembuf
