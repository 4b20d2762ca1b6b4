#include "process/tls_files.h"

#include <openssl/bio.h>
#include <openssl/err.h>
#include <openssl/pem.h>
#include <openssl/x509.h>

#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <stdexcept>

namespace dembuf::server {

namespace {

// A PEM file is a few kilobytes; anything much larger is not one.
constexpr std::uintmax_t kMaxPemBytes = 1 << 20;

std::string ReadPemFile(const std::string& setting, const std::string& path) {
  namespace fs = std::filesystem;
  std::error_code error;
  const fs::file_status status = fs::status(path, error);
  auto problem = [&](const std::string& what) {
    return std::runtime_error("tls: " + setting + " " + path + ": " + what);
  };
  if (error || !fs::exists(status)) throw problem("no such file");
  if (fs::is_directory(status)) throw problem("a folder, not a PEM file");
  if (!fs::is_regular_file(status)) throw problem("not a regular file");
  if (fs::file_size(path, error) > kMaxPemBytes) throw problem("larger than 1 MiB: not a PEM file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw problem("cannot be read (permissions?)");
  std::ostringstream text;
  text << in.rdbuf();
  if (text.str().empty()) throw problem("empty");
  return text.str();
}

// OpenSSL's last error, in words ("" when it has none).
std::string OpenSslError() {
  const unsigned long code = ERR_get_error();
  ERR_clear_error();
  if (code == 0) return "";
  char text[256];
  ERR_error_string_n(code, text, sizeof text);
  return std::string(" (") + text + ")";
}

}  // namespace

TlsFiles ReadTlsFiles(const std::string& cert_path, const std::string& key_path) {
  TlsFiles files{ReadPemFile("tls_cert", cert_path), ReadPemFile("tls_key", key_path)};
  ERR_clear_error();
  using Bio = std::unique_ptr<BIO, decltype(&BIO_free)>;
  Bio cert_bio(
      BIO_new_mem_buf(files.certificate_pem.data(), static_cast<int>(files.certificate_pem.size())),
      &BIO_free);
  std::unique_ptr<X509, decltype(&X509_free)> certificate(
      PEM_read_bio_X509(cert_bio.get(), nullptr, nullptr, nullptr), &X509_free);
  if (!certificate)
    throw std::runtime_error("tls: tls_cert " + cert_path +
                             ": holds no PEM certificate (\"-----BEGIN CERTIFICATE-----\")" +
                             OpenSslError());
  Bio key_bio(BIO_new_mem_buf(files.key_pem.data(), static_cast<int>(files.key_pem.size())),
              &BIO_free);
  std::unique_ptr<EVP_PKEY, decltype(&EVP_PKEY_free)> key(
      PEM_read_bio_PrivateKey(key_bio.get(), nullptr, nullptr, nullptr), &EVP_PKEY_free);
  if (!key)
    throw std::runtime_error("tls: tls_key " + key_path + ": holds no unencrypted PEM private key" +
                             OpenSslError());
  if (X509_check_private_key(certificate.get(), key.get()) != 1)
    throw std::runtime_error("tls: tls_key " + key_path + " is not the key of tls_cert " +
                             cert_path + OpenSslError());
  return files;
}

}  // namespace dembuf::server
