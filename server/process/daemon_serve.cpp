// dembufd serving: the database locked and opened, the executor, the gRPC server and the web
// pages started, then a wait for a stop signal and a graceful stop.
#include <grpcpp/grpcpp.h>
#include <grpcpp/health_check_service_interface.h>
#include <grpcpp/resource_quota.h>
#include <spdlog/sinks/base_sink.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <csignal>
#include <cstring>
#include <filesystem>
#include <iostream>

#include "access/access_policy.h"
#include "access/auth.h"
#include "dembuf/study/files/provenance.h"
#include "dembuf/study/version.h"
#include "doors/reflection_v1.h"
#include "doors/service.h"
#include "doors/web/web_server.h"
#include "jobs/slurm_executor.h"
#include "jobs/thread_executor.h"
#include "notify/notifier.h"
#include "process/daemon.h"
#include "process/instance.h"
#include "process/secret_file.h"
#include "process/tls_files.h"
#include "store/owned_files.h"
#include "store/store.h"

namespace dembuf::server {

namespace {

// A part of the start-up failed; the reason is in the log already.
struct StartFailed {};

// Unary calls one connection may have open at once, beside its long streams.
constexpr int kUnaryCallsPerConnection = 100;

// The log file, appended to through a descriptor the daemon opened itself in a folder of its
// own: spdlog's file sink opens a name, and would follow a link planted there (log lines with
// a job's name appended to the daemon's account's .bashrc).
class OwnedLogSink final : public spdlog::sinks::base_sink<std::mutex> {
 public:
  explicit OwnedLogSink(const std::string& path) {
    const std::filesystem::path file = std::filesystem::absolute(path);
    const OwnedFolder folder = OwnedFolder::Open(file.parent_path(), "the log folder", false);
    m_fd = folder.OpenToAppend(file.filename().string());
  }
  ~OwnedLogSink() override { close(m_fd); }

 private:
  void sink_it_(const spdlog::details::log_msg& message) override {
    spdlog::memory_buf_t line;
    formatter_->format(message, line);
    // One write a line (O_APPEND): lines of two writers never interleave within a line.
    if (write(m_fd, line.data(), line.size()) < 0) {
      // a full disk loses log lines, not the daemon
    }
  }
  void flush_() override {}

  int m_fd = -1;
};

std::shared_ptr<spdlog::logger> MakeLogger(const ServerConfig& config) {
  std::vector<spdlog::sink_ptr> sinks;
  sinks.push_back(std::make_shared<spdlog::sinks::stderr_color_sink_mt>());
  if (!config.log_file.empty()) sinks.push_back(std::make_shared<OwnedLogSink>(config.log_file));
  auto log = std::make_shared<spdlog::logger>("dembufd", sinks.begin(), sinks.end());
  log->set_level(spdlog::level::from_str(config.log_level));
  log->flush_on(spdlog::level::info);
  return log;
}

// SIGTERM, SIGINT and SIGHUP (a closed terminal, or a service manager's reload) are taken by
// one thread with sigwait; every other thread (gRPC's, the workers', OpenMP's) inherits the
// blocked mask and never sees them. Each stops the daemon gracefully: SIGHUP's default would
// kill it at once, with running jobs counted as crashed.
sigset_t BlockStopSignals() {
  sigset_t stop_signals;
  sigemptyset(&stop_signals);
  sigaddset(&stop_signals, SIGTERM);
  sigaddset(&stop_signals, SIGINT);
  sigaddset(&stop_signals, SIGHUP);
  pthread_sigmask(SIG_BLOCK, &stop_signals, nullptr);
  return stop_signals;
}

// A program installed beside this one (dembuf beside dembufd), else its name, found in PATH.
std::string BesideThisProgram(const std::string& name) {
  std::error_code error;
  const std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe", error);
  if (!error && std::filesystem::exists(self.parent_path() / name))
    return (self.parent_path() / name).string();
  return name;
}

std::unique_ptr<Executor> MakeExecutor(const ServerConfig& config, Store& store,
                                       const std::shared_ptr<spdlog::logger>& log) {
  if (config.executor == "slurm") {
    SlurmExecutorOptions options;
    const slurm::Settings& s = config.slurm;
    options.slurm = s;
    options.queue_limit = config.queue_limit;
    // The ceiling on any job's files read back from a node; each job's own bound is its
    // estimate (SlurmExecutor::ResultBytesMax), as a node's files are not trusted.
    options.max_result_bytes = config.quota_output_mb > 0
                                   ? static_cast<std::uint64_t>(2 * config.quota_output_mb * 1e6)
                                   : UINT64_MAX;
    options.dembuf = !s.dembuf.empty() ? s.dembuf : BesideThisProgram("dembuf");
    // A relative path means from here, not from the job's folder on a node.
    if (options.dembuf.find('/') != std::string::npos)
      options.dembuf = std::filesystem::absolute(options.dembuf).string();
    return std::make_unique<SlurmExecutor>(store, options, log);
  }
  ThreadExecutorOptions options;
  options.workers = config.workers;
  options.threads_per_job = config.threads_per_job;
  options.queue_limit = config.queue_limit;
  options.storage_retry = std::chrono::seconds(config.storage_retry_s);
  options.host = report::HostName();
  return std::make_unique<ThreadExecutor>(store, options, log);
}

// What the service says of itself and the limits it applies to requests.
ServiceInfo MakeServiceInfo(const ServerConfig& config) {
  ServiceInfo info;
  info.database = config.db;
  info.host = report::HostName();
  info.started_at = report::UtcNow();
  info.max_sweep_jobs = config.max_sweep_jobs;
  info.quota_queued_jobs = config.quota_queued_jobs;
  info.quota_stored_bytes = static_cast<std::int64_t>(config.quota_stored_mb * 1e6);
  info.job_limits.beads = config.quota_beads;
  info.job_limits.steps = config.quota_steps;
  info.job_limits.bead_steps = config.quota_bead_steps;
  info.job_limits.samples = config.quota_samples;
  info.job_limits.memory_bytes = config.quota_memory_mb * 1e6;
  info.job_limits.output_bytes = config.quota_output_mb * 1e6;
  info.max_watch_streams_per_user = config.max_watch_streams_per_user;
  info.max_watch_streams = config.max_watch_streams;
  info.max_fetch_streams_per_user = config.max_fetch_streams_per_user;
  info.max_fetch_streams = config.max_fetch_streams;
  info.stream_write_timeout = std::chrono::seconds(config.stream_write_timeout_s);
  info.max_bed_push_bytes = std::int64_t{config.max_bed_push_mb} << 20;
  return info;
}

std::shared_ptr<grpc::ServerCredentials> Credentials(const ServerConfig& config,
                                                     spdlog::logger& log) {
  if (!IsLoopback(config.listen))
    log.warn(
        "listening on {} for other machines: this gRPC does not withstand an HTTP/2 rapid "
        "reset flood (CVE-2023-44487); put haproxy in front and listen on loopback "
        "(deploy/haproxy/, docs/service.md)",
        config.listen);
  if (config.tls_cert.empty()) {
    if (!IsLoopback(config.listen))
      log.warn(
          "listening on {} without TLS: tokens and data cross the network in clear text "
          "(set tls_cert and tls_key)",
          config.listen);
    return grpc::InsecureServerCredentials();
  }
  grpc::SslServerCredentialsOptions ssl;
  try {
    const TlsFiles tls = ReadTlsFiles(config.tls_cert, config.tls_key);
    ssl.pem_key_cert_pairs.push_back({tls.key_pem, tls.certificate_pem});
  } catch (const std::exception& e) {
    log.critical("{}", e.what());
    throw StartFailed{};
  }
  return grpc::SslServerCredentials(ssl);
}

// The gRPC server with its services, listening; its port in `port`.
std::unique_ptr<grpc::Server> StartGrpc(const ServerConfig& config, DembufService& service,
                                        ReflectionV1Service& reflection, spdlog::logger& log,
                                        int& port) {
  grpc::EnableDefaultHealthCheckService(true);
  grpc::ServerBuilder builder;
  builder.AddListeningPort(config.listen, Credentials(config, log), &port);
  // One daemon per port: gRPC would share it (SO_REUSEPORT) with a daemon already there.
  builder.AddChannelArgument(GRPC_ARG_ALLOW_REUSEPORT, 0);
  // Requests larger than a page of scene text are not read, and none is decompressed: this
  // gRPC inflates a compressed message whole before it compares it with the limit (a 382 KB
  // gzip request became 384 MB), so compressed requests are refused unread.
  builder.SetMaxReceiveMessageSize(config.max_request_kb * 1024);
  builder.SetCompressionAlgorithmSupportStatus(GRPC_COMPRESS_DEFLATE, false);
  builder.SetCompressionAlgorithmSupportStatus(GRPC_COMPRESS_GZIP, false);
  // gRPC refuses a compressed request by its header only: it is told to inflate none at all
  // (a compressed message that passed would then not parse, and be refused as such).
  builder.AddChannelArgument(GRPC_ARG_ENABLE_PER_MESSAGE_DECOMPRESSION, 0);
  // What one connection may hold: streams at once (a flood of streams from one connection
  // meets this; a client's channels share one connection, so it is as wide as the daemon's
  // own caps on long streams, with room for the unary calls), and how often it may ping
  // (gRPC's defaults, said here).
  builder.AddChannelArgument(GRPC_ARG_MAX_CONCURRENT_STREAMS,
                             config.max_watch_streams + config.max_fetch_streams + kMaxBedPushes +
                                 kUnaryCallsPerConnection);
  builder.AddChannelArgument(GRPC_ARG_HTTP2_MAX_PING_STRIKES, 2);
  builder.AddChannelArgument(GRPC_ARG_HTTP2_MIN_RECV_PING_INTERVAL_WITHOUT_DATA_MS, 300000);
  // A connection left idle is closed after a while; one held long is asked to go (its
  // streams finish first), so that no connection holds the daemon's memory for ever.
  builder.AddChannelArgument(GRPC_ARG_MAX_CONNECTION_IDLE_MS, 15 * 60 * 1000);
  builder.AddChannelArgument(GRPC_ARG_MAX_CONNECTION_AGE_MS, 4 * 3600 * 1000);
  // gRPC's own memory for connections and calls, bounded; its sync threads serve only the
  // reflection streams (each holding one). Every other call is on the callback API.
  grpc::ResourceQuota quota("dembufd");
  quota.SetMaxThreads(kReflectionStreams + 4);
  quota.Resize(std::size_t{1} << 30);
  builder.SetResourceQuota(quota);
  builder.RegisterService(&service);
  builder.RegisterService(&reflection);
  std::unique_ptr<grpc::Server> server = builder.BuildAndStart();
  if (!server || port == 0) {
    const int wanted = ListenPort(config.listen);
    const std::string holder = wanted > 0 ? PortHolder(wanted) : "";
    log.critical("cannot listen on {}: {}", config.listen,
                 !holder.empty() ? config.listen + " is in use by " + holder
                 : wanted > 0    ? "in use (ss -ltnp shows by what), or not an address of this "
                                   "machine"
                                 : "not an address this machine can listen on");
    throw StartFailed{};
  }
  // Health answers for the service's name too (grpc_health_probe -service=dembuf.v1.Dembuf),
  // not only for the server as a whole ("").
  server->GetHealthCheckService()->SetServingStatus(v1::Dembuf::service_full_name(), true);
  return server;
}

// The web pages: the same store and running jobs, on an address of their own.
std::unique_ptr<web::WebServer> StartWebPages(const ServerConfig& config, Store& store,
                                              Executor& executor, const AccessPolicy& policy,
                                              const ServiceInfo& info,
                                              const std::shared_ptr<spdlog::logger>& log) {
  web::WebOptions options;
  options.listen = config.http;
  options.tls_cert = config.tls_cert;
  options.tls_key = config.tls_key;
  options.max_streams_per_user = config.http_max_streams_per_user;
  options.max_streams = config.http_max_streams;
  options.host = info.host;
  options.started_at = info.started_at;
  auto web_server = std::make_unique<web::WebServer>(store, executor, policy, options, log);
  try {
    web_server->Start();
  } catch (const std::exception& e) {
    const int wanted = std::stoi(config.http.substr(config.http.rfind(':') + 1));
    const std::string holder = wanted > 0 ? PortHolder(wanted) : "";
    log->critical("{}{}", e.what(), holder.empty() ? "" : ": in use by " + holder);
    throw StartFailed{};
  }
  const std::string web_address =
      config.http.substr(0, config.http.rfind(':') + 1) + std::to_string(web_server->port());
  if (config.tls_cert.empty() && !IsLoopback(config.http))
    log->warn(
        "web pages on {} without TLS: tokens and data cross the network in clear text "
        "(set tls_cert and tls_key)",
        web_address);
  if (!IsLoopback(config.http))
    log->warn(
        "web pages on {}: a connection holds one of their threads until its request is "
        "whole, and a client that sends it slowly holds it for hours; where other machines "
        "reach them, serve them on loopback behind haproxy (deploy/haproxy/dembufd.cfg)",
        web_address);
  log->info("web pages on {}://{}/{}", config.tls_cert.empty() ? "http" : "https", web_address,
            policy.tokens_required() ? " (tokens required)" : "");
  return web_server;
}

}  // namespace

int Serve(const ServerConfig& config) {
  const sigset_t stop_signals = BlockStopSignals();
  std::shared_ptr<spdlog::logger> log;
  try {
    log = MakeLogger(config);
  } catch (const std::exception& e) {
    std::cerr << "dembufd: log_file: " << e.what() << "\n";
    return kDaemonRuntime;
  }
  // One daemon per database: the lock first, so that a second daemon touches nothing.
  std::unique_ptr<DatabaseLock> lock;
  std::unique_ptr<Store> store;
  try {
    lock = std::make_unique<DatabaseLock>(config.db);
    lock->Describe("process " + std::to_string(getpid()) + ", starting");
    if (const std::string opened = lock->MakePrivate(); !opened.empty())
      log->warn("{} could be read by other accounts; made readable by this one only", opened);
    store = std::make_unique<Store>(config.db);
  } catch (const std::exception& e) {
    log->critical("{}", e.what());
    return kDaemonRuntime;
  }
  // Before the port is bound: an executor whose folders cannot be used stops the start.
  std::unique_ptr<Executor> executor;
  try {
    executor = MakeExecutor(config, *store, log);
  } catch (const std::exception& e) {
    log->critical("{}", e.what());
    return kDaemonRuntime;
  }
  // Before the port is bound too: a hook that cannot be used stops the start.
  std::unique_ptr<Notifier> notifier;
  if (!config.notify_url_file.empty()) {
    try {
      NotifierOptions options;
      options.url = ReadHookUrl(config.notify_url_file);
      options.mention = config.notify_mention;
      notifier = std::make_unique<Notifier>(*store, options, log);
    } catch (const std::exception& e) {
      log->critical("{}", e.what());
      return kDaemonRuntime;
    }
  }
  ServiceInfo info = MakeServiceInfo(config);
  info.notify = notifier != nullptr;
  // One access policy for gRPC, the web pages and their files.
  AccessPolicy policy(*store, config.access == "local" ? AccessMode::kLocal : AccessMode::kTokens);
  if (policy.tokens_required() && !store->AnyUsers())
    log->warn(
        "tokens are required but none exists: make one with dembufd --db {} token-create "
        "NAME [--admin]",
        config.db);
  DembufService service(*store, *executor, policy, info, log);
  // Reflection v1 only, with its streams capped and its callers identified as every other
  // call's: gRPC's v1alpha service held a thread per stream without a cap (250 silent streams
  // starved every other call).
  ReflectionV1Service reflection({v1::Dembuf::service_full_name(), "grpc.health.v1.Health",
                                  grpc::reflection::v1::ServerReflection::service_full_name()},
                                 kReflectionStreams, &policy);
  std::unique_ptr<grpc::Server> server;
  std::unique_ptr<web::WebServer> web_server;
  int port = 0;
  try {
    server = StartGrpc(config, service, reflection, *log, port);
    const std::string address =
        config.listen.substr(0, config.listen.rfind(':') + 1) + std::to_string(port);
    lock->Describe("process " + std::to_string(getpid()) + ", listening on " + address +
                   ", since " + info.started_at);
    if (!config.http.empty())
      web_server = StartWebPages(config, *store, *executor, policy, info, log);
  } catch (const StartFailed&) {
    if (server) server->Shutdown();
    return kDaemonRuntime;
  }
  executor->Start();
  if (notifier) notifier->Start();
  log->info("dembufd {} listening on {} (port {}), database {}{}{}", kVersion, config.listen, port,
            config.db, config.tls_cert.empty() ? "" : ", TLS",
            policy.tokens_required() ? ", tokens required" : ", access local: no tokens");

  int signal = 0;
  sigwait(&stop_signals, &signal);
  log->info("{}: shutting down: no new requests; running jobs get {} s", strsignal(signal),
            config.shutdown_grace_s);
  // Watch streams end when their job ends or the deadline passes.
  if (web_server) web_server->Stop();
  server->Shutdown(std::chrono::system_clock::now() + std::chrono::seconds(2));
  executor->Shutdown(std::chrono::seconds(config.shutdown_grace_s));
  // What it still owes (a job that ended in the grace) is sent by the next start.
  if (notifier) notifier->Shutdown();
  notifier.reset();
  // (The policy's reader of the users read a closed store: a crash one stop in fifty.)
  policy.Stop();
  store.reset();
  log->info("stopped cleanly");
  return kDaemonDone;
}

}  // namespace dembuf::server
