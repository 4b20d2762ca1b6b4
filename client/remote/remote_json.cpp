#include "remote/remote_json.h"

namespace dembuf::cli {

nlohmann::json ServerInfoJson(const v1::ServerInfoResponse& info, const std::string& address) {
  return {
      {"version", info.version()},
      {"address", address},
      {"host", info.host()},
      {"started_at", info.started_at()},
      {"executor", info.executor()},
      {"workers", info.workers()},
      {"threads_per_job", info.threads_per_job()},
      {"running", info.running()},
      {"queue_depth", info.queue_depth()},
      {"queue_limit", info.queue_limit()},
      {"database", info.database().empty() ? nlohmann::json() : nlohmann::json(info.database())},
      {"stored_bytes", info.stored_bytes()},
      {"quota_stored_bytes", info.quota_stored_bytes()},
      {"queued_jobs", info.queued_jobs()},
      {"quota_queued_jobs", info.quota_queued_jobs()},
      {"notify", info.notify()}};
}

}  // namespace dembuf::cli
