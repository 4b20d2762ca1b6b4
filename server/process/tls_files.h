// The TLS certificate and key, checked before a server is built on them: gRPC and httplib
// report a bad file only as a server that cannot start ("cannot listen ...: in use").
#pragma once

#include <string>

namespace dembuf::server {

/// The PEM certificate chain and private key files read whole, after checking that each is
/// a readable regular file holding what its setting says and that the key is the
/// certificate's. Throws std::runtime_error naming the setting, the file and what is wrong.
struct TlsFiles {
  std::string certificate_pem;
  std::string key_pem;
};
TlsFiles ReadTlsFiles(const std::string& cert_path, const std::string& key_path);

}  // namespace dembuf::server
