#include "dembuf/study/text/sha256.h"

#include <openssl/evp.h>

#include <stdexcept>

namespace dembuf {

struct Sha256Stream::Context {
  EVP_MD_CTX* evp = EVP_MD_CTX_new();
  ~Context() { EVP_MD_CTX_free(evp); }
};

Sha256Stream::Sha256Stream() : m_context(std::make_unique<Context>()) {
  if (!m_context->evp || EVP_DigestInit_ex(m_context->evp, EVP_sha256(), nullptr) != 1)
    throw std::runtime_error("SHA-256 failed");
}

Sha256Stream::~Sha256Stream() = default;

void Sha256Stream::Add(std::string_view piece) {
  if (EVP_DigestUpdate(m_context->evp, piece.data(), piece.size()) != 1)
    throw std::runtime_error("SHA-256 failed");
}

std::string Sha256Stream::Hex() {
  unsigned char digest[EVP_MAX_MD_SIZE];
  unsigned int length = 0;
  if (EVP_DigestFinal_ex(m_context->evp, digest, &length) != 1)
    throw std::runtime_error("SHA-256 failed");
  static const char* const kDigits = "0123456789abcdef";
  std::string hex;
  for (unsigned int i = 0; i < length; ++i) {
    hex += kDigits[digest[i] >> 4];
    hex += kDigits[digest[i] & 0xf];
  }
  return hex;
}

std::string Sha256Hex(std::string_view bytes) {
  Sha256Stream hash;
  hash.Add(bytes);
  return hash.Hex();
}

}  // namespace dembuf
