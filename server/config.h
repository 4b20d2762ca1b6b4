// dembufd's settings: defaults, then the configuration file, then the command line.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>

namespace dembuf::server {

struct ServerConfig {
  std::string listen = "127.0.0.1:50051";  ///< loopback unless told otherwise
  std::string db = "dembuf.db";
  int workers = 1;
  int threads_per_job = 0;  ///< 0: the cores divided among the workers
  int queue_limit = 1000;
  int max_sweep_jobs = 10000;
  std::string log_file;  ///< "" for the console only
  std::string log_level = "info";
  int shutdown_grace_s = 10;  ///< how long SIGTERM waits for running jobs
  int storage_retry_s = 30;   ///< pause after the disk was found full, before the next job
  /// Every request must carry a user's token. Always so when listening beyond loopback.
  bool require_tokens = false;
  std::string tls_cert;       ///< PEM certificate chain; with tls_key, the daemon speaks TLS only
  std::string tls_key;        ///< PEM private key
  int quota_queued_jobs = 0;  ///< per user; 0: no limit beyond queue_limit
  std::int64_t quota_beads = 0;  ///< largest bed (estimated bead count) per job; 0: no limit
  std::int64_t quota_steps = 0;  ///< most time steps (estimated) per job; 0: no limit
};

/// A setting is unknown, of the wrong type or out of range; the message names it.
class ConfigError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Reads a TOML configuration file over `config` (keys as the struct's members). Throws
/// ConfigError naming the file and key for unknown keys, wrong types or bad values, and for
/// a file past the limits of text inputs (dembuf/engine/text_limits.h).
void LoadConfigFile(const std::string& path, ServerConfig& config);
/// The same for the file's text (`path` names it in messages).
void LoadConfigText(const std::string& text, const std::string& path, ServerConfig& config);

/// Checks ranges; throws ConfigError naming the setting.
void ValidateConfig(ServerConfig& config);

}  // namespace dembuf::server
