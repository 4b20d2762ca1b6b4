#include "access/auth.h"

#include <cctype>
#include <cstdio>
#include <fstream>
#include <stdexcept>

#include "dembuf/study/files/provenance.h"

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

std::string UserNameProblem(const std::string& name) {
  if (name.empty() || name.size() > 64)
    return std::string("\"")
        .append(name.substr(0, 80))
        .append(name.size() > 80 ? "...\"" : "\"")
        .append(" must be 1 to 64 characters (it has " + std::to_string(name.size()) + ")");
  for (char c : name)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '_' || c == '-'))
      return "\"" + name + "\" may hold only letters, digits, '.', '_' and '-'";
  return "";
}

bool IsLoopback(const std::string& listen) {
  if (listen.rfind("unix:", 0) == 0) return true;
  const auto colon = listen.rfind(':');
  const std::string host = listen.substr(0, colon);
  return host == "localhost" || host == "[::1]" || host == "::1" || host.rfind("127.", 0) == 0;
}

}  // namespace dembuf::server
