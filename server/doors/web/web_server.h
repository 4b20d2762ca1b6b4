// The web side of dembufd (--http): pages that show the jobs, a running impact's plate force
// as it arrives and a sweep's curve as its points finish, over a small read-only JSON API and
// Server-Sent Events. It reads the same store and running jobs as the gRPC service.
//
// Access is the daemon's one policy (access_policy.h), as for gRPC: a user's token in an
// "Authorization: Bearer" header or through the login form (a session cookie); users see their
// own jobs and sweeps, admins all. With tls_cert and tls_key it speaks HTTPS only.
#pragma once

#include <spdlog/logger.h>

#include <atomic>
#include <memory>
#include <string>
#include <thread>

#include "access/access_policy.h"
#include "jobs/executor.h"
#include "store/store.h"

namespace httplib {
class Server;
}  // namespace httplib

namespace dembuf::server::web {

struct WebOptions {
  std::string listen;    ///< "HOST:PORT" (port 0: any free port)
  std::string tls_cert;  ///< PEM files; both or neither
  std::string tls_key;
  int max_streams_per_user = 8;
  int max_streams = 64;
  std::string host;        ///< this machine's name, shown on the pages
  std::string started_at;  ///< the daemon's start time
};

class WebServer {
 public:
  WebServer(Store& store, Executor& executor, const AccessPolicy& policy, WebOptions options,
            std::shared_ptr<spdlog::logger> log);
  ~WebServer();
  WebServer(const WebServer&) = delete;
  WebServer& operator=(const WebServer&) = delete;

  /// Binds the address and starts serving on threads of its own. Throws std::runtime_error
  /// naming the address when it cannot be bound (or the TLS files cannot be used).
  void Start();
  /// The port bound (the one chosen, for port 0).
  int port() const { return m_port; }
  /// Ends the event streams and stops serving; returns when every request has ended.
  void Stop();

 private:
  class Routes;

  Store& m_store;
  Executor& m_executor;
  const AccessPolicy& m_policy;
  WebOptions m_options;
  std::shared_ptr<spdlog::logger> m_log;
  std::unique_ptr<Routes> m_routes;
  std::unique_ptr<httplib::Server> m_server;
  std::thread m_listener;
  int m_port = 0;
};

}  // namespace dembuf::server::web
