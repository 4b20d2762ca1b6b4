#include "auth.h"

#include <cstdio>
#include <fstream>
#include <stdexcept>

#include "digest.h"

namespace dembuf::server {

std::string NewToken() {
  unsigned char bytes[32];
  std::ifstream random("/dev/urandom", std::ios::binary);
  if (!random.read(reinterpret_cast<char*>(bytes), sizeof bytes))
    throw std::runtime_error("cannot read /dev/urandom for a token");
  static const char* const kDigits = "0123456789abcdef";
  std::string token;
  for (unsigned char b : bytes) {
    token += kDigits[b >> 4];
    token += kDigits[b & 0xf];
  }
  return token;
}

std::string HashToken(const std::string& token) {
  return Sha256Hex(token);
}

bool IsLoopback(const std::string& listen) {
  const auto colon = listen.rfind(':');
  const std::string host = listen.substr(0, colon);
  return host == "localhost" || host == "[::1]" || host == "::1" || host.rfind("127.", 0) == 0;
}

}  // namespace dembuf::server
