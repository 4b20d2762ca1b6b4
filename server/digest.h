// SHA-256, for API tokens (only their hashes are stored) and the checksums of stored series.
#pragma once

#include <string>
#include <string_view>

namespace dembuf::server {

/// The SHA-256 of the bytes, as 64 hex digits.
std::string Sha256Hex(std::string_view bytes);

}  // namespace dembuf::server
