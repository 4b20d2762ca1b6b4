// dembufd: the dembuf daemon. Serves the gRPC API of proto/dembuf/v1, keeps everything in one
// SQLite database and runs the queued jobs on a pool of workers.
//
// Exit codes: 0 after a clean shutdown (SIGTERM or SIGINT), 1 when a database or address
// cannot be used (or another runtime failure), 2 for bad flags or settings.
#include <grpcpp/grpcpp.h>
#include <grpcpp/health_check_service_interface.h>
#include <grpcpp/resource_quota.h>
#include <spdlog/sinks/basic_file_sink.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>
#include <sys/stat.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <cctype>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>
#include <thread>

#include "access_policy.h"
#include "auth.h"
#include "config.h"
#include "dembuf/study/files/provenance.h"
#include "dembuf/study/version.h"
#include "instance.h"
#include "reflection_v1.h"
#include "service.h"
#include "slurm_executor.h"
#include "store.h"
#include "thread_executor.h"
#include "tls_files.h"
#include "web_server.h"

using namespace dembuf::server;

namespace {

constexpr int kExitRuntime = 1;
constexpr int kExitBadInput = 2;

std::shared_ptr<spdlog::logger> MakeLogger(const ServerConfig& config) {
  std::vector<spdlog::sink_ptr> sinks;
  sinks.push_back(std::make_shared<spdlog::sinks::stderr_color_sink_mt>());
  if (!config.log_file.empty())
    sinks.push_back(std::make_shared<spdlog::sinks::basic_file_sink_mt>(config.log_file));
  auto log = std::make_shared<spdlog::logger>("dembufd", sinks.begin(), sinks.end());
  log->set_level(spdlog::level::from_str(config.log_level));
  log->flush_on(spdlog::level::info);
  return log;
}

// A program installed beside this one (dembuf beside dembufd), else its name, found in PATH.
std::string BesideThisProgram(const std::string& name) {
  std::error_code error;
  const std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe", error);
  if (!error && std::filesystem::exists(self.parent_path() / name))
    return (self.parent_path() / name).string();
  return name;
}

}  // namespace

int main(int argc, char** argv) {
  ServerConfig config;
  std::string config_file;
  CLI::App app{"dembufd: the dembuf daemon (gRPC API, job queue, SQLite store)"};
  app.set_version_flag("--version", std::string("dembufd ") + dembuf::kVersion);
  app.add_option("--config", config_file, "TOML configuration file (flags override it)")
      ->check(CLI::ExistingFile);
  // Flags are read into a second copy so that only the given ones override the file.
  ServerConfig flags;
  auto* listen = app.add_option("--listen", flags.listen, "address to serve, host:port");
  auto* db = app.add_option("--db", flags.db, "SQLite database file (created if absent)");
  auto* workers = app.add_option("--workers", flags.workers, "jobs run at once");
  auto* threads = app.add_option("--threads-per-job", flags.threads_per_job,
                                 "engine threads per job (0: cores / workers)");
  auto* queue = app.add_option("--queue-limit", flags.queue_limit, "queued jobs at most");
  auto* log_file = app.add_option("--log-file", flags.log_file, "also log to this file");
  auto* log_level = app.add_option("--log-level", flags.log_level,
                                   "trace, debug, info, warn, error, critical or off");
  auto* grace = app.add_option("--shutdown-grace", flags.shutdown_grace_s,
                               "seconds SIGTERM waits for running jobs before requeueing them");
  auto* retry = app.add_option("--storage-retry", flags.storage_retry_s,
                               "seconds to wait before the next job once the disk was full");
  auto* http = app.add_option("--http", flags.http,
                              "also serve the web pages on HOST:PORT (a port alone: on "
                              "loopback); off unless set");
  auto* access = app.add_option("--access", flags.access,
                                "who may call: tokens (every request carries a user's token; the "
                                "default) or local (a call without a token is this machine's "
                                "trusted user, an admin; every address must be on loopback)");
  auto* executor = app.add_option("--executor", flags.executor,
                                  "where jobs run: threads (this machine) or slurm (the cluster "
                                  "of the configuration's [slurm] table)");
  // Token administration: works on the database, does not start the server.
  std::string user;
  bool admin = false;
  CLI::App* create = app.add_subcommand("token-create", "make (or replace) a user's API token");
  create->add_option("name", user, "user name")->required();
  create->add_flag("--admin", admin, "the user sees and cancels every job");
  CLI::App* revoke = app.add_subcommand("token-revoke", "remove a user's API token");
  revoke->add_option("name", user, "user name")->required();
  CLI::App* list = app.add_subcommand("token-list", "list the users that have tokens");
  bool check_db = false;
  app.add_flag("--check-db", check_db,
               "verify the database offline (SQLite's integrity check, then every stored "
               "summary, series and result file against its checksum) and exit: 0 intact, 1 "
               "damaged; refused while a daemon uses it");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help and --version end the program well; any other parse error is bad input.
    return app.exit(e) == 0 ? 0 : kExitBadInput;
  }

  // Everything the daemon creates (the database, its side files, logs, results, a unix
  // socket) is its own account's alone: the database holds every user's work.
  umask(0077);
  try {
    if (!config_file.empty()) LoadConfigFile(config_file, config);
    if (*listen) config.listen = flags.listen;
    if (*db) config.db = flags.db;
    if (*workers) config.workers = flags.workers;
    if (*threads) config.threads_per_job = flags.threads_per_job;
    if (*queue) config.queue_limit = flags.queue_limit;
    if (*log_file) config.log_file = flags.log_file;
    if (*log_level) config.log_level = flags.log_level;
    if (*grace) config.shutdown_grace_s = flags.shutdown_grace_s;
    if (*retry) config.storage_retry_s = flags.storage_retry_s;
    if (*executor) config.executor = flags.executor;
    if (*http) config.http = flags.http;
    if (*access) config.access = flags.access;
    ValidateConfig(config);
  } catch (const ConfigError& e) {
    std::cerr << "dembufd: " << e.what() << "\n";
    return kExitBadInput;
  }

  if (create->parsed() || revoke->parsed() || list->parsed()) {
    try {
      MakeDatabasePrivate(config.db);
      Store store(config.db);
      if (create->parsed()) {
        if (const std::string problem = UserNameProblem(user); !problem.empty()) {
          std::cerr << "dembufd: name: " << problem << "\n";
          return kExitBadInput;
        }
        const std::string token = NewToken();
        store.SetUser(user, HashToken(token), admin);
        std::printf("%s\n", token.c_str());
        std::fprintf(stderr,
                     "token for %s%s (shown once; the database keeps only its hash); the "
                     "user sets DEMBUF_TOKEN to it\n",
                     user.c_str(), admin ? " (admin)" : "");
      } else if (revoke->parsed()) {
        if (!store.RemoveUser(user)) throw std::runtime_error("no user " + user);
        std::fprintf(stderr, "token of %s removed\n", user.c_str());
      } else {
        for (const User& u : store.ListUsers())
          std::printf("%s%s\n", u.name.c_str(), u.admin ? " (admin)" : "");
      }
      return 0;
    } catch (const std::exception& e) {
      std::cerr << "dembufd: " << e.what() << "\n";
      return kExitRuntime;
    }
  }

  if (check_db) {
    try {
      // The lock first: the check reads a database no daemon is changing.
      DatabaseLock lock(config.db);
      Store store(config.db);
      const CheckReport report = store.Check();
      for (const std::string& problem : report.problems) std::printf("%s\n", problem.c_str());
      std::printf(
          "database %s: %lld summaries, %lld series chunks and %lld result files checked: %s\n",
          config.db.c_str(), static_cast<long long>(report.summaries),
          static_cast<long long>(report.series_chunks), static_cast<long long>(report.files),
          report.problems.empty() ? "intact"
                                  : (std::to_string(report.problems.size()) + " damaged").c_str());
      return report.problems.empty() ? 0 : kExitRuntime;
    } catch (const std::exception& e) {
      std::cerr << "dembufd: " << e.what() << "\n";
      return kExitRuntime;
    }
  }

  // SIGTERM, SIGINT and SIGHUP (a closed terminal, or a service manager's reload) are taken by
  // one thread with sigwait; every other thread (gRPC's, the workers', OpenMP's) inherits the
  // blocked mask and never sees them. Each stops the daemon gracefully: SIGHUP's default
  // would kill it at once, with running jobs counted as crashed.
  sigset_t stop_signals;
  sigemptyset(&stop_signals);
  sigaddset(&stop_signals, SIGTERM);
  sigaddset(&stop_signals, SIGINT);
  sigaddset(&stop_signals, SIGHUP);
  pthread_sigmask(SIG_BLOCK, &stop_signals, nullptr);

  std::shared_ptr<spdlog::logger> log;
  try {
    log = MakeLogger(config);
  } catch (const std::exception& e) {
    std::cerr << "dembufd: log_file: " << e.what() << "\n";
    return kExitRuntime;
  }
  // One daemon per database: the lock first, so that a second daemon touches nothing.
  std::unique_ptr<DatabaseLock> lock;
  std::unique_ptr<Store> store;
  try {
    lock = std::make_unique<DatabaseLock>(config.db);
    if (const std::string opened = MakeDatabasePrivate(config.db); !opened.empty())
      log->warn("{} could be read by other accounts; made readable by this one only", opened);
    store = std::make_unique<Store>(config.db);
  } catch (const std::exception& e) {
    log->critical("{}", e.what());
    return kExitRuntime;
  }

  std::unique_ptr<Executor> executor_ptr;
  if (config.executor == "slurm") {
    SlurmExecutorOptions options;
    const ServerConfig::Slurm& s = config.slurm;
    options.slurm = {s.partition,  s.account,  s.cpus_per_job, s.mem_per_job_mb, s.time_limit,
                     s.extra_args, s.work_dir, s.dembuf,       s.poll_s};
    options.queue_limit = config.queue_limit;
    // A job's files were bounded by its estimate at submission; the bound read back is wider
    // (the estimate is an upper bound, but a cluster node's files are not trusted).
    options.max_result_bytes = config.quota_output_mb > 0
                                   ? static_cast<std::uint64_t>(2 * config.quota_output_mb * 1e6)
                                   : UINT64_MAX;
    options.dembuf = !s.dembuf.empty() ? s.dembuf : BesideThisProgram("dembuf");
    // A relative path means from here, not from the job's folder on a node.
    if (options.dembuf.find('/') != std::string::npos)
      options.dembuf = std::filesystem::absolute(options.dembuf).string();
    executor_ptr = std::make_unique<SlurmExecutor>(*store, options, log);
  } else {
    ThreadExecutorOptions options;
    options.workers = config.workers;
    options.threads_per_job = config.threads_per_job;
    options.queue_limit = config.queue_limit;
    options.storage_retry = std::chrono::seconds(config.storage_retry_s);
    options.host = dembuf::report::HostName();
    executor_ptr = std::make_unique<ThreadExecutor>(*store, options, log);
  }
  Executor& scheduler = *executor_ptr;
  ServiceInfo info;
  info.database = config.db;
  info.host = dembuf::report::HostName();
  info.started_at = dembuf::report::UtcNow();
  info.max_sweep_jobs = config.max_sweep_jobs;
  // One access policy for gRPC, the web pages and their files.
  const AccessPolicy policy(*store,
                            config.access == "local" ? AccessMode::kLocal : AccessMode::kTokens);
  info.quota_queued_jobs = config.quota_queued_jobs;
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
  if (policy.tokens_required() && !store->AnyUsers())
    log->warn(
        "tokens are required but none exists: make one with dembufd --db {} token-create "
        "NAME [--admin]",
        config.db);
  DembufService service(*store, scheduler, policy, info, log);

  grpc::EnableDefaultHealthCheckService(true);
  grpc::ServerBuilder builder;
  int port = 0;
  std::shared_ptr<grpc::ServerCredentials> credentials = grpc::InsecureServerCredentials();
  if (!config.tls_cert.empty()) {
    grpc::SslServerCredentialsOptions ssl;
    try {
      const TlsFiles tls = ReadTlsFiles(config.tls_cert, config.tls_key);
      ssl.pem_key_cert_pairs.push_back({tls.key_pem, tls.certificate_pem});
    } catch (const std::exception& e) {
      log->critical("{}", e.what());
      return kExitRuntime;
    }
    credentials = grpc::SslServerCredentials(ssl);
  } else if (!IsLoopback(config.listen)) {
    log->warn(
        "listening on {} without TLS: tokens and data cross the network in clear text "
        "(set tls_cert and tls_key)",
        config.listen);
  }
  builder.AddListeningPort(config.listen, credentials, &port);
  // One daemon per port: gRPC would share it (SO_REUSEPORT) with a daemon already there.
  builder.AddChannelArgument(GRPC_ARG_ALLOW_REUSEPORT, 0);
  // Requests larger than a page of scene text are not read. The pool serves the unary calls and
  // the reflection streams (at most kReflectionStreams, each holding a thread); the job and
  // result streams hold none (gRPC's callback API), so it need not grow with them.
  builder.SetMaxReceiveMessageSize(config.max_request_kb * 1024);
  constexpr int kReflectionStreams = 16;
  grpc::ResourceQuota thread_pool("dembufd");
  thread_pool.SetMaxThreads(64 + kReflectionStreams);
  builder.SetResourceQuota(thread_pool);
  builder.RegisterService(&service);
  // Reflection v1 only, with its streams capped: gRPC's v1alpha service held a thread per
  // stream without a cap (250 silent streams starved every other call).
  ReflectionV1Service reflection_v1(
      {dembuf::v1::Dembuf::service_full_name(), "grpc.health.v1.Health",
       grpc::reflection::v1::ServerReflection::service_full_name()},
      kReflectionStreams);
  builder.RegisterService(&reflection_v1);
  std::unique_ptr<grpc::Server> server = builder.BuildAndStart();
  if (!server || port == 0) {
    const int wanted = ListenPort(config.listen);
    const std::string holder = wanted > 0 ? PortHolder(wanted) : "";
    log->critical("cannot listen on {}: {}", config.listen,
                  !holder.empty() ? config.listen + " is in use by " + holder
                  : wanted > 0    ? "in use (ss -ltnp shows by what), or not an address of this "
                                    "machine"
                                  : "not an address this machine can listen on");
    return kExitRuntime;
  }
  // Health answers for the service's name too (grpc_health_probe -service=dembuf.v1.Dembuf),
  // not only for the server as a whole ("").
  server->GetHealthCheckService()->SetServingStatus(dembuf::v1::Dembuf::service_full_name(), true);
  const std::string address =
      config.listen.substr(0, config.listen.rfind(':') + 1) + std::to_string(port);
  lock->Describe("process " + std::to_string(getpid()) + ", listening on " + address + ", since " +
                 info.started_at);
  // The web pages: the same store and running jobs, on an address of their own.
  std::unique_ptr<web::WebServer> web_server;
  if (!config.http.empty()) {
    web::WebOptions options;
    options.listen = config.http;
    options.tls_cert = config.tls_cert;
    options.tls_key = config.tls_key;
    options.max_streams_per_user = config.http_max_streams_per_user;
    options.max_streams = config.http_max_streams;
    options.host = info.host;
    options.started_at = info.started_at;
    web_server = std::make_unique<web::WebServer>(*store, scheduler, policy, options, log);
    try {
      web_server->Start();
    } catch (const std::exception& e) {
      const int wanted = std::stoi(config.http.substr(config.http.rfind(':') + 1));
      const std::string holder = wanted > 0 ? PortHolder(wanted) : "";
      log->critical("{}{}", e.what(), holder.empty() ? "" : ": in use by " + holder);
      server->Shutdown();
      return kExitRuntime;
    }
    const std::string web_address =
        config.http.substr(0, config.http.rfind(':') + 1) + std::to_string(web_server->port());
    if (config.tls_cert.empty() && !IsLoopback(config.http))
      log->warn(
          "web pages on {} without TLS: tokens and data cross the network in clear text "
          "(set tls_cert and tls_key)",
          web_address);
    log->info("web pages on {}://{}/{}", config.tls_cert.empty() ? "http" : "https", web_address,
              policy.tokens_required() ? " (tokens required)" : "");
  }
  scheduler.Start();
  log->info("dembufd {} listening on {} (port {}), database {}{}{}", dembuf::kVersion,
            config.listen, port, config.db, config.tls_cert.empty() ? "" : ", TLS",
            policy.tokens_required() ? ", tokens required" : ", access local: no tokens");

  int signal = 0;
  sigwait(&stop_signals, &signal);
  log->info("{}: shutting down: no new requests; running jobs get {} s", strsignal(signal),
            config.shutdown_grace_s);
  // Watch streams end when their job ends or the deadline passes.
  if (web_server) web_server->Stop();
  server->Shutdown(std::chrono::system_clock::now() + std::chrono::seconds(2));
  scheduler.Shutdown(std::chrono::seconds(config.shutdown_grace_s));
  store.reset();
  log->info("stopped cleanly");
  return 0;
}
