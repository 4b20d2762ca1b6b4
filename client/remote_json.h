// The daemon's answers as JSON, for scripts (`--json` on list, status and server-info). The
// names are those of the web pages' JSON API (docs/service.md), and stay: ids and counts are
// numbers, states are the CLI's names ("done"), a job's summary is its summary.json object.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "dembuf/v1/dembuf.pb.h"

namespace dembuf::cli {

/// "queued", "preparing_bed", "running", "done", "failed", "cancelled".
std::string StateText(v1::JobState state);

/// A job; `details` adds its scene, hashes, summary, result files and prepared beds. Throws
/// InputLimitError for a summary past the bounds of JSON taken from outside.
nlohmann::json JobJson(const v1::Job& job, bool details);
nlohmann::json SweepJson(const v1::Sweep& sweep);
nlohmann::json ServerInfoJson(const v1::ServerInfoResponse& info, const std::string& address);

}  // namespace dembuf::cli
