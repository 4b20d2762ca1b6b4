// dembufd's settings: defaults, then the configuration file, then the command line.
#pragma once

#include "jobs/slurm.h"

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace dembuf::server {

/// workers = "auto": one worker per CPU this process may use; the running jobs share the
/// CPUs by what their beds can feed (schedule.h).
inline constexpr int kAutoWorkers = 0;

struct ServerConfig {
  std::string listen = "127.0.0.1:50051";  ///< loopback unless told otherwise
  std::string db = "dembuf.db";
  int workers = 0;           ///< kAutoWorkers ("auto"): one per usable CPU
  int threads_per_job = 0;   ///< 0: the usable CPUs divided among the workers
  int queue_limit = 100000;  ///< queued jobs at most, of all users
  int max_sweep_jobs = 10000;
  std::string log_file;  ///< "" for the console only
  std::string log_level = "info";
  int shutdown_grace_s = 10;  ///< how long SIGTERM waits for running jobs
  int storage_retry_s = 30;   ///< pause after the disk was found full, before the next job
  /// How callers are identified, on every address alike: "tokens" (every request carries a
  /// user's token) or "local" (a request without one comes from this machine's trusted
  /// user, an admin; refused unless every address is on loopback).
  std::string access = "tokens";
  std::string tls_cert;  ///< PEM certificate chain; with tls_key, the daemon speaks TLS only
  std::string tls_key;   ///< PEM private key
  /// Per user, so that one user's sweep cannot fill the queue: queued jobs (a sweep of
  /// max_sweep_jobs fits), and the results stored of their jobs. 0: no limit.
  int quota_queued_jobs = 10000;
  double quota_stored_mb = 10000;
  /// Watch streams open at once, per user and in all. A stream holds no thread (gRPC's
  /// callback API): an idle one costs a few kilobytes and a look at its job twice a second.
  int max_watch_streams_per_user = 8;
  int max_watch_streams = 1024;
  /// Result streams (FetchSeries, FetchFiles) open at once, per user and in all: each reads
  /// the store while it sends.
  int max_fetch_streams_per_user = 4;
  int max_fetch_streams = 64;
  /// A stream whose client has not taken a message for this long is closed (a client that
  /// stopped reading holds no place and no buffers).
  int stream_write_timeout_s = 30;
  int max_request_kb = 1024;  ///< the largest request read (a scene file is a few kB)
  /// The largest bed one PushBed may send (held in memory until checked and stored); at most
  /// kMaxBedPushes pushes at once, one a user.
  int max_bed_push_mb = 64;
  /// The web pages and their JSON API (read-only), "HOST:PORT" or a port alone (on
  /// loopback); "" for none. Beyond loopback they need a user's token, as gRPC does.
  std::string http;
  /// Event streams of the web pages open at once, per user and in all: each holds one of the
  /// web server's threads, and its pool is sized above the total.
  int http_max_streams_per_user = 8;
  int http_max_streams = 64;
  // Per job, against its resource estimate (dembuf/study/run/resource_estimate.h) before it is
  // accepted; 0: no limit. The defaults pass the paper's experiments at the reference
  // accuracy with room to spare and refuse what would take the server for days.
  double quota_beads = 1e6;        ///< beads in its largest bed (E2's source bed: 36,805)
  double quota_steps = 1e9;        ///< time steps, settling counted at bed.max_settle_s
  double quota_bead_steps = 1e12;  ///< beads times steps: about 17 core-hours
  double quota_samples = 1e6;      ///< force samples written (48 MB stored)
  double quota_memory_mb = 4096;   ///< peak memory of the run
  double quota_output_mb = 1024;   ///< result files stored (E5's six snapshots: 120 MB)

  /// A file holding the URL of the chat hook (a Mattermost or Slack incoming webhook) that
  /// jobs and sweeps submitted with --notify are told to when they end; "": none. The URL
  /// is a secret (whoever has it may post), so it is kept out of this file.
  std::string notify_url_file;
  bool notify_mention = false;  ///< messages begin with "@user" (the chat's user of that name)

  /// Where jobs run: "threads" (the daemon's workers) or "slurm" (the [slurm] table's cluster).
  std::string executor = "threads";
  /// The [slurm] table: what the daemon asks of the cluster (slurm::Settings owns the list).
  slurm::Settings slurm;

  /// (For the test that the example configuration states these defaults.)
  bool operator==(const ServerConfig&) const = default;
};

/// A setting is unknown, of the wrong type or out of range; the message names it.
class ConfigError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Reads a TOML configuration file over `config` (keys as the struct's members). Throws
/// ConfigError naming the file and key for unknown keys, wrong types or bad values, and for
/// a file past the limits of text inputs (dembuf/study/text/text_limits.h).
void LoadConfigFile(const std::string& path, ServerConfig& config);
/// The same for the file's text (`path` names it in messages).
void LoadConfigText(const std::string& text, const std::string& path, ServerConfig& config);

/// Applies one `--setting KEY=VALUE` flag: any key of the configuration file (slurm.KEY for the
/// [slurm] table), the value as TOML or, when it is not a TOML value, as text. Throws
/// ConfigError naming the key as the file's settings do.
void ApplySettingFlag(const std::string& assignment, ServerConfig& config);

/// Every setting as a configuration file would say it (dembufd --check-config prints it).
std::string ConfigText(const ServerConfig& config);

/// The port of a listen address "HOST:PORT" or "[IPv6]:PORT" (0: any free port); -1 for a
/// "unix:PATH" socket. Throws ConfigError naming `listen` for anything else.
/// A worker count as written in the configuration or on the command line: 1 to 256, or
/// "auto" (kAutoWorkers). Throws ConfigError naming the value and the range.
int ParseWorkers(const std::string& text);

int ListenPort(const std::string& listen);

/// The web side's address: "HOST:PORT", or "127.0.0.1:PORT" for a port alone. Throws
/// ConfigError naming `http` for anything else.
std::string HttpAddress(const std::string& http);

/// Checks ranges; throws ConfigError naming the setting.
void ValidateConfig(ServerConfig& config);

}  // namespace dembuf::server
