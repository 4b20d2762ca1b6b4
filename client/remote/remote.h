// The client's remote mode: commands that talk to a dembufd over gRPC. Each returns the
// process exit code and prints server errors as one line naming the field at fault.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace dembuf::cli {

/// Where the daemon is: --server, else $DEMBUF_SERVER, else the daemon's default address.
std::string ServerAddress(const std::string& flag);
/// True when --server or $DEMBUF_SERVER names a daemon (so that `sweep` goes there).
bool ServerGiven(const std::string& flag);

struct RemoteScene {
  std::string scene_file;  ///< sent as text; the server resolves and checks it
  std::string preset;
  std::string accuracy;
  std::vector<std::string> overrides;
};

struct Remote {
  std::string address;
  std::string owner;         ///< --owner, else $USER (a token's user overrides it on the server)
  std::string token;         ///< --token, else $DEMBUF_TOKEN: sent as "authorization: Bearer ..."
  std::string tls_ca;        ///< --tls-ca, else $DEMBUF_TLS_CA: PEM file; speak TLS trusting it
  std::string command_line;  ///< this program's arguments, sent with jobs as provenance
};

/// What a submission asks besides its scene.
struct SubmitOptions {
  std::string name;
  bool notify = false;    ///< the daemon's chat hook tells of the end
  bool no_reuse = false;  ///< run even where a stored result of the same scene could answer
};
int RemoteSubmit(const Remote& remote, const RemoteScene& scene, const SubmitOptions& options);
/// Prints the sweep's id (with `json`: the sweep and its job ids as JSON). `table`: a file of
/// chosen points (sweep --table), or "".
int RemoteSweep(const Remote& remote, const RemoteScene& scene,
                const std::vector<std::string>& vary, const std::string& table, int seeds,
                const SubmitOptions& options, bool json);
struct ListOptions {
  std::string state;
  std::string owner;
  std::int64_t sweep = 0;
  int limit = 20;
  bool sweeps = false;  ///< list sweeps instead of jobs
  bool json = false;    ///< print JSON (api_json.h) instead of a table
};
int RemoteList(const Remote& remote, const ListOptions& options);
int RemoteStatus(const Remote& remote, std::int64_t id, bool sweep, bool json);
/// Live view of a job; `csv` prints every sample as a CSV row instead.
int RemoteWatch(const Remote& remote, std::int64_t id, bool csv, std::int64_t from_index);
/// A job's files (or, with `sweep`, every job's and the sweep's tables) into `out_dir`, which
/// must be new or empty unless `force` (then the files of an earlier fetch are replaced).
int RemoteFetch(const Remote& remote, std::int64_t id, bool sweep, const std::string& out_dir,
                bool plots, bool force, bool long_table = false);
/// Follows a sweep until every job of it has ended, a line each time its counts change; 0 when
/// every job is done, kExitFailed when one failed, else kExitCancelled when one was cancelled.
int RemoteWatchSweep(const Remote& remote, std::int64_t id);
int RemoteCancel(const Remote& remote, std::int64_t id, bool sweep);
/// Deletes an ended job (or sweep, with its jobs) and its stored results.
int RemoteDelete(const Remote& remote, std::int64_t id, bool sweep);
/// Pushes the prepared beds of a scene (each of its stages found in `bed_cache`) into the
/// server's bed cache, where its jobs find them instead of preparing them again.
int RemotePushBeds(const Remote& remote, const RemoteScene& scene, const std::string& bed_cache);
int RemoteServerInfo(const Remote& remote, bool json);

}  // namespace dembuf::cli
