// SHA-256 digests (OpenSSL's), as 64 hex digits: of a scene's text, a bed's contents, a
// stored file and a token. Unlike ContentHash, they hold against deliberate collisions.
#pragma once

#include <memory>
#include <string>
#include <string_view>

namespace dembuf {

/// The SHA-256 of the bytes, as 64 hex digits (OpenSSL's).
std::string Sha256Hex(std::string_view bytes);

/// SHA-256 of bytes given piece by piece (a stored file checked without holding it whole).
class Sha256Stream {
 public:
  Sha256Stream();
  ~Sha256Stream();
  Sha256Stream(const Sha256Stream&) = delete;
  Sha256Stream& operator=(const Sha256Stream&) = delete;
  void Add(std::string_view piece);
  /// The digest of everything added, as 64 hex digits; the stream is spent.
  std::string Hex();

 private:
  struct Context;
  std::unique_ptr<Context> m_context;
};

}  // namespace dembuf
