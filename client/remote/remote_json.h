// The daemon's own facts as JSON, for scripts (`dembuf server-info --json`). Jobs and sweeps
// are api_json.h's.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "dembuf/v1/dembuf.pb.h"

namespace dembuf::cli {

nlohmann::json ServerInfoJson(const v1::ServerInfoResponse& info, const std::string& address);

}  // namespace dembuf::cli
