#include "doors/web/web_server.h"

#include <httplib.h>
#include <sys/socket.h>

#include <cctype>
#include <charconv>
#include <chrono>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "access/auth.h"
#include "api_json.h"
#include "dembuf/study/files/run_output.h"
#include "dembuf/study/version.h"
#include "doors/api_messages.h"
#include "doors/stream_limits.h"
#include "doors/web/sessions.h"
#include "doors/web/web_assets.h"
#include "doors/web/web_views.h"
#include "jobs/job_feed.h"

namespace dembuf::server::web {

namespace {

using Clock = std::chrono::steady_clock;
using httplib::Request;
using httplib::Response;

constexpr const char* kSessionCookie = "dembuf_session";
// An event stream reads the job at most five times a second (a page draws no faster), and
// sends at most this many samples in one event.
constexpr auto kStreamPace = std::chrono::milliseconds(200);
constexpr std::size_t kSamplesPerEvent = 4096;
// Files are sent in pieces, never held whole.
constexpr std::int64_t kFilePieceBytes = 1 << 20;
constexpr std::int64_t kCsvPieceSamples = 1 << 14;

/// A request the API refuses, with the HTTP status and the reason.
struct Refusal {
  int status;
  std::string message;
};

void SendJson(Response& res, const nlohmann::json& body, int status = 200) {
  res.status = status;
  res.set_header("Cache-Control", "no-store");
  res.set_content(body.dump(), "application/json");
}

void SendRefusal(Response& res, const Refusal& refusal) {
  SendJson(res, {{"error", refusal.message}}, refusal.status);
}

/// A whole number from a query parameter or path, within [min, max]; throws a Refusal (400)
/// naming the parameter, the value and the range.
std::int64_t ParseNumber(const std::string& text, const std::string& name, std::int64_t min,
                         std::int64_t max) {
  std::int64_t value = 0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (error != std::errc() || end != text.data() + text.size() || value < min || value > max)
    throw Refusal{400, name + ": \"" + text.substr(0, 40) + (text.size() > 40 ? "..." : "") +
                           "\" must be a whole number from " + std::to_string(min) + " to " +
                           std::to_string(max)};
  return value;
}

std::int64_t ParamNumber(const Request& req, const std::string& name, std::int64_t fallback,
                         std::int64_t min, std::int64_t max) {
  return req.has_param(name) ? ParseNumber(req.get_param_value(name), name, min, max) : fallback;
}

/// The value of one cookie of the Cookie header, "" when absent.
std::string CookieValue(const std::string& header, const std::string& name) {
  std::size_t at = 0;
  while (at < header.size()) {
    const std::size_t end = std::min(header.find(';', at), header.size());
    std::string_view pair(header.data() + at, end - at);
    while (!pair.empty() && pair.front() == ' ') pair.remove_prefix(1);
    if (pair.size() > name.size() && pair.substr(0, name.size()) == name &&
        pair[name.size()] == '=')
      return std::string(pair.substr(name.size() + 1));
    at = end + 1;
  }
  return "";
}

/// A redirect target after login: a path of this site only ("/..." but not "//host").
std::string LocalPath(const std::string& next) {
  if (next.size() > 200 || next.empty() || next[0] != '/' || (next.size() > 1 && next[1] == '/') ||
      next.find('\\') != std::string::npos)
    return "/";
  for (unsigned char c : next)
    if (c < 0x21 || c == 0x7f) return "/";
  return next;
}

/// "HOST:PORT" or "[IPv6]:PORT" split for binding.
std::pair<std::string, int> SplitAddress(const std::string& listen) {
  const auto colon = listen.rfind(':');
  std::string host = listen.substr(0, colon);
  if (host.size() >= 2 && host.front() == '[' && host.back() == ']')
    host = host.substr(1, host.size() - 2);
  return {host, std::stoi(listen.substr(colon + 1))};
}

/// The content type of a result file, by its extension; never one a browser would run.
const char* FileType(const std::string& path) {
  auto ends = [&](const char* suffix) {
    const std::string s(suffix);
    return path.size() >= s.size() && path.compare(path.size() - s.size(), s.size(), s) == 0;
  };
  if (ends(".csv")) return "text/csv";
  if (ends(".json")) return "application/json";
  if (ends(".png")) return "image/png";
  return "text/plain";
}

/// One Server-Sent Event, its data a line of JSON text.
std::string Event(const std::string& type, const std::string& data, std::int64_t id = -1) {
  std::string text;
  if (id >= 0) text += "id: " + std::to_string(id) + "\n";
  text += "event: " + type + "\ndata: " + data + "\n\n";
  return text;
}
std::string Event(const std::string& type, const nlohmann::json& data) {
  return Event(type, data.dump());
}

}  // namespace

class WebServer::Routes {
 public:
  Routes(Store& store, Executor& executor, const AccessPolicy& policy, const WebOptions& options,
         std::shared_ptr<spdlog::logger> log)
      : m_store(store),
        m_executor(executor),
        m_policy(policy),
        m_options(options),
        m_log(std::move(log)),
        m_streams(options.max_streams_per_user, options.max_streams, "event streams",
                  "http_max_streams") {}

  void Install(httplib::Server& server) {
    // Pages (the scripts fetch their data from the API).
    Page(server, "/", "index.html");
    Page(server, R"(/jobs/\d{1,18})", "job.html");
    Page(server, R"(/sweeps/\d{1,18})", "sweep.html");
    server.Get("/login", [](const Request&, Response& res) { Asset(res, "login.html"); });
    server.Get(R"(/static/([A-Za-z0-9._-]{1,100}))", [](const Request& req, Response& res) {
      if (!Asset(res, req.matches[1].str())) SendRefusal(res, {404, "no such file"});
    });
    server.Post("/login", [this](const Request& req, Response& res) { Login(req, res); });
    server.Post("/logout", [this](const Request& req, Response& res) { Logout(req, res); });

    // The API.
    Api(server, "/api/server",
        [this](const Caller& caller, const Request&, Response& res) { ServerInfo(caller, res); });
    Api(server, "/api/jobs", [this](const Caller& caller, const Request& req, Response& res) {
      ListJobs(caller, req, res);
    });
    Api(server, R"(/api/jobs/(\d{1,18}))",
        [this](const Caller& caller, const Request& req, Response& res) {
          const JobRecord job = VisibleJob(caller, req.matches[1].str(), Action::kRead);
          SendJson(res, JobJson(m_store, m_executor, job, /*details=*/true));
        });
    Api(server, R"(/api/jobs/(\d{1,18})/events)",
        [this](const Caller& caller, const Request& req, Response& res) {
          Events(caller, req, res);
        });
    Api(server, R"(/api/jobs/(\d{1,18})/files/(.+))",
        [this](const Caller& caller, const Request& req, Response& res) {
          File(caller, req, res);
        });
    Api(server, "/api/sweeps", [this](const Caller& caller, const Request& req, Response& res) {
      ListSweeps(caller, req, res);
    });
    Api(server, R"(/api/sweeps/(\d{1,18}))",
        [this](const Caller& caller, const Request& req, Response& res) {
          const auto sweep =
              m_store.GetSweep(ParseNumber(req.matches[1].str(), "id", 1, INT64_MAX));
          if (!sweep) throw Refusal{404, "id: no sweep " + req.matches[1].str()};
          AccessPolicy::Require(caller, Action::kRead, sweep->owner,
                                "id: sweep " + std::to_string(sweep->id));
          SendJson(res, SweepJson(m_store, *sweep));
        });
  }

  /// Ends the event streams at their next read.
  void Stop() { m_stopping = true; }

 private:
  using ApiHandler = std::function<void(const Caller&, const Request&, Response&)>;

  /// Serves a compiled-in file; false when there is none of that name.
  static bool Asset(Response& res, const std::string& name) {
    const WebAsset* asset = FindWebAsset(name);
    if (!asset) return false;
    res.set_content(std::string(asset->bytes), std::string(asset->content_type));
    // The pages change with the daemon: revalidated each time, cheap from a loopback.
    res.set_header("Cache-Control", "no-cache");
    return true;
  }

  /// Who asks, by the access policy, from a bearer token or a session cookie. Throws the
  /// policy's AccessDenied for a request that does not say who it is where that is required.
  Caller Identify(const Request& req) {
    std::optional<std::string> authorization;
    if (req.has_header("Authorization")) authorization = req.get_header_value("Authorization");
    std::optional<std::string> session_token_hash;
    if (const std::string session = CookieValue(req.get_header_value("Cookie"), kSessionCookie);
        !session.empty())
      session_token_hash = m_sessions.TokenHash(session);
    return m_policy.Identify(authorization, session_token_hash);
  }

  /// A page for those who may see it; others are sent to the login form.
  void Page(httplib::Server& server, const std::string& pattern, std::string asset) {
    server.Get(pattern, [this, asset](const Request& req, Response& res) {
      try {
        Identify(req);
      } catch (const AccessDenied&) {
        res.set_redirect("/login?next=" + httplib::detail::encode_query_param(req.path), 303);
        return;
      }
      Asset(res, asset);
    });
  }

  /// An API route: the caller identified, refusals and failures answered as JSON.
  void Api(httplib::Server& server, const std::string& pattern, ApiHandler handler) {
    server.Get(pattern, [this, handler](const Request& req, Response& res) {
      try {
        handler(Identify(req), req, res);
      } catch (const Refusal& refusal) {
        SendRefusal(res, refusal);
      } catch (const AccessDenied& e) {
        SendRefusal(res, {e.unauthenticated() ? 401 : 403, e.what()});
      } catch (const std::exception& e) {
        m_log->error("web: {}: {}", req.path, e.what());
        SendRefusal(res, {500, std::string("the server failed: ") + e.what()});
      }
    });
  }

  /// A form post comes from these pages: a browser sends Origin, and it must be this site.
  static bool SameOrigin(const Request& req) {
    if (!req.has_header("Origin")) return true;  // not a browser's cross-site form
    const std::string origin = req.get_header_value("Origin");
    const std::string host = req.get_header_value("Host");
    return origin == "http://" + host || origin == "https://" + host;
  }

  std::string CookieAttributes() const {
    return "; Path=/; HttpOnly; SameSite=Strict" +
           std::string(m_options.tls_cert.empty() ? "" : "; Secure");
  }

  void Login(const Request& req, Response& res) {
    if (!SameOrigin(req)) return SendRefusal(res, {403, "Origin: not this site"});
    const std::string token = req.get_param_value("token");
    const std::string next = LocalPath(req.get_param_value("next"));
    const std::optional<Caller> caller = token.empty() ? std::nullopt : m_policy.HolderOf(token);
    if (!caller) {
      m_log->warn("web: a login from {} with an unknown token", req.remote_addr);
      res.set_redirect("/login?failed=1&next=" + httplib::detail::encode_query_param(next), 303);
      return;
    }
    const std::string session = m_sessions.Open(HashToken(token));
    res.set_header("Set-Cookie", std::string(kSessionCookie) + "=" + session + CookieAttributes() +
                                     "; Max-Age=" + std::to_string(m_sessions.lifetime().count()));
    m_log->info("web: {} logged in from {}", caller->name, req.remote_addr);
    res.set_redirect(next, 303);
  }

  void Logout(const Request& req, Response& res) {
    if (!SameOrigin(req)) return SendRefusal(res, {403, "Origin: not this site"});
    const std::string session = CookieValue(req.get_header_value("Cookie"), kSessionCookie);
    if (!session.empty()) m_sessions.Close(session);
    res.set_header("Set-Cookie",
                   std::string(kSessionCookie) + "=" + CookieAttributes() + "; Max-Age=0");
    res.set_redirect("/login", 303);
  }

  void ServerInfo(const Caller& caller, Response& res) {
    const ExecutorInfo executor = m_executor.info();
    SendJson(res,
             {{"version", kVersion},
              {"host", m_options.host},
              {"started_at", m_options.started_at},
              {"executor", executor.kind},
              {"workers", executor.workers},
              {"threads_per_job", executor.threads_per_job},
              {"queue_depth", m_executor.queued()},
              {"queue_limit", executor.queue_limit},
              {"running", m_executor.running()},
              {"tokens_required", m_policy.tokens_required()},
              {"user", {{"name", caller.name}, {"admin", caller.admin}, {"token", caller.token}}}});
  }

  /// Job `id_text`, when it exists and the caller may do `action` to it.
  JobRecord VisibleJob(const Caller& caller, const std::string& id_text, Action action) {
    const std::int64_t id = ParseNumber(id_text, "id", 1, INT64_MAX);
    std::optional<JobRecord> job = m_store.GetJob(id);
    if (!job) throw Refusal{404, "id: no job " + std::to_string(id)};
    AccessPolicy::Require(caller, action, job->owner, "id: job " + std::to_string(id));
    return *job;
  }

  void ListJobs(const Caller& caller, const Request& req, Response& res) {
    JobFilter filter;
    filter.limit = static_cast<int>(ParamNumber(req, "limit", 100, 1, 1000));
    filter.sweep_id = ParamNumber(req, "sweep", 0, 0, INT64_MAX);
    if (req.has_param("state")) {
      const std::string state = req.get_param_value("state");
      filter.state = ParseState(state);
      if (!filter.state)
        throw Refusal{400, "state: \"" + state.substr(0, 40) +
                               "\" must be queued, preparing_bed, running, done, failed or "
                               "cancelled"};
    }
    filter.owner = AccessPolicy::ListedOwner(caller, "");
    filter.with_scene = false;  // a listing shows no scene
    nlohmann::json jobs = nlohmann::json::array();
    for (const JobRecord& job : m_store.ListJobs(filter))
      jobs.push_back(JobJson(m_store, m_executor, job, /*details=*/false));
    SendJson(res, {{"jobs", jobs}});
  }

  void ListSweeps(const Caller& caller, const Request& req, Response& res) {
    const int limit = static_cast<int>(ParamNumber(req, "limit", 100, 1, 1000));
    // The sweeps as `dembuf list --sweeps --json` has them, from the same messages.
    v1::ListSweepsResponse listed;
    if (!FillSweepList(m_store, AccessPolicy::ListedOwner(caller, ""), limit,
                       listed.mutable_sweeps()))
      throw Refusal{400, "limit: the " + std::to_string(limit) +
                             " newest sweeps would make an answer of more than " +
                             std::to_string(kMaxListAnswerBytes >> 20) +
                             " MiB; ask for fewer (limit)"};
    nlohmann::json sweeps = nlohmann::json::array();
    for (const v1::Sweep& sweep : listed.sweeps()) sweeps.push_back(api::SweepJson(sweep, false));
    SendJson(res, {{"sweeps", sweeps}});
  }

  /// A result file of an ended job: its series as plate_force.csv, its summary.json, or a
  /// stored file (snapshots, the bare-plate series), by the exact stored path only.
  void File(const Caller& caller, const Request& req, Response& res) {
    const JobRecord job = VisibleJob(caller, req.matches[1].str(), Action::kFetch);
    const std::string path = req.matches[2].str();
    if (!IsFinal(job.state))
      throw Refusal{409, "id: job " + std::to_string(job.id) + " is " + StateName(job.state) +
                             "; its files come when it ends"};
    // Saved under its own name, never shown as a page.
    auto attachment = [&] {
      std::string name = path.substr(path.rfind('/') + 1);
      for (char& c : name)
        if (!std::isalnum(static_cast<unsigned char>(c)) && c != '.' && c != '-') c = '_';
      res.set_header("Content-Disposition", "attachment; filename=\"" + name + "\"");
      res.set_header("Cache-Control", "no-store");
    };
    if (path == report::run_files::kSummary) {
      const std::string summary = m_store.Summary(job.id);
      if (summary.empty())
        throw Refusal{404, "path: job " + std::to_string(job.id) + " has no summary"};
      attachment();
      res.set_content(summary, "application/json");
      return;
    }
    Store& store = m_store;
    const std::int64_t id = job.id;
    if (path == report::run_files::kPlateForce) {
      attachment();
      res.set_chunked_content_provider(
          "text/csv", [&store, id](std::size_t, httplib::DataSink& sink) {
            // The header, then the rows piece by piece, as SamplesToCsv writes them whole.
            std::int64_t from = 0;
            for (bool first = true;; first = false) {
              const std::vector<ImpactSample> piece =
                  store.ReadResultSeries(id, from, kCsvPieceSamples);
              std::string text = report::SamplesToCsv(piece);
              if (!first) text.erase(0, text.find('\n') + 1);
              if (!text.empty() && !sink.write(text.data(), text.size())) return false;
              from += static_cast<std::int64_t>(piece.size());
              if (static_cast<std::int64_t>(piece.size()) < kCsvPieceSamples) break;
            }
            sink.done();
            return true;
          });
      return;
    }
    for (const JobFileInfo& file : m_store.JobFiles(job.id)) {
      if (file.path != path) continue;
      attachment();
      res.set_content_provider(
          static_cast<std::size_t>(file.size), FileType(path),
          [&store, id, path](std::size_t offset, std::size_t length, httplib::DataSink& sink) {
            const std::string piece = store.ReadJobFile(
                id, path, static_cast<std::int64_t>(offset),
                std::min<std::int64_t>(static_cast<std::int64_t>(length), kFilePieceBytes));
            return !piece.empty() && sink.write(piece.data(), piece.size());
          });
      return;
    }
    throw Refusal{404, "path: job " + std::to_string(job.id) + " has no file \"" +
                           path.substr(0, 200) + "\""};
  }

  /// Server-Sent Events of a job: "samples" (batches of its force series, each with the index
  /// after it as its id, so that a reconnecting page resumes with Last-Event-ID), "progress"
  /// (state and progress, when they change and every second), and "end" when it has ended.
  void Events(const Caller& caller, const Request& req, Response& res) {
    const JobRecord job = VisibleJob(caller, req.matches[1].str(), Action::kWatch);
    std::int64_t from = ParamNumber(req, "from", 0, 0, INT64_MAX);
    if (req.has_header("Last-Event-ID"))
      from = ParseNumber(req.get_header_value("Last-Event-ID"), "Last-Event-ID", 0, INT64_MAX);
    std::string why;
    std::optional<StreamLimits::Place> place = m_streams.Take(caller, &why);
    if (!place) throw Refusal{429, "event streams: " + why + "; close a page, or wait"};

    struct Stream {
      Stream(JobFeed f, StreamLimits::Place p, std::int64_t from)
          : feed(std::move(f)), place(std::move(p)), next(from) {}
      JobFeed feed;
      StreamLimits::Place place;
      std::int64_t next;
      Clock::time_point next_read{};
      Clock::time_point last_progress{};
      std::string last_state;
      bool first = true;
      Caller caller;  ///< who opened it: the stream ends when their token is withdrawn
    };
    auto stream =
        std::make_shared<Stream>(JobFeed(m_store, m_executor, job.id), std::move(*place), from);
    stream->caller = caller;
    res.set_header("Cache-Control", "no-store");
    res.set_header("X-Accel-Buffering", "no");  // a proxy in front must not hold events back
    res.set_chunked_content_provider("text/event-stream", [this, stream](std::size_t,
                                                                         httplib::DataSink& sink) {
      Stream& s = *stream;
      if (m_stopping) {
        sink.done();
        return true;
      }
      std::this_thread::sleep_until(s.next_read);
      if (!m_policy.StillValid(s.caller)) {
        const std::string text =
            Event("revoked", {{"error", "your token was revoked or replaced: log in again"}});
        sink.write(text.data(), text.size());
        sink.done();
        return true;
      }
      // (Half a second at most: a withdrawn token ends the stream within a second.)
      const FeedRead read = s.feed.Read(s.next, kSamplesPerEvent, std::chrono::milliseconds(500));
      // A full batch: more are waiting (a late page catching up), read again at once.
      s.next_read =
          read.samples.size() == kSamplesPerEvent ? Clock::now() : Clock::now() + kStreamPace;
      std::string text = s.first ? "retry: 2000\n\n" : "";
      if (!read.found) {
        text += Event("gone", {{"error", "the job is gone"}});
        sink.write(text.data(), text.size());
        sink.done();
        return true;
      }
      if (!read.samples.empty()) {
        text += Event("samples", SamplesJson(s.next, read.samples),
                      s.next + static_cast<std::int64_t>(read.samples.size()));
        s.next += static_cast<std::int64_t>(read.samples.size());
      }
      const std::string state = StateName(read.state);
      const auto now = Clock::now();
      if (s.first || read.ended || state != s.last_state ||
          now - s.last_progress >= std::chrono::seconds(1)) {
        text += Event("progress", ProgressJson(read.state, read.progress));
        s.last_progress = now;
        s.last_state = state;
      }
      if (read.ended) text += Event("end", {{"state", state}, {"samples", s.next}});
      s.first = false;
      if (text.empty()) text = ":\n\n";  // a comment: tells whether the page is still there
      if (!sink.write(text.data(), text.size())) return false;
      if (read.ended) sink.done();
      return true;
    });
  }

  Store& m_store;
  Executor& m_executor;
  const AccessPolicy& m_policy;
  const WebOptions& m_options;
  std::shared_ptr<spdlog::logger> m_log;
  Sessions m_sessions;
  StreamLimits m_streams;
  std::atomic<bool> m_stopping{false};
};

WebServer::WebServer(Store& store, Executor& executor, const AccessPolicy& policy,
                     WebOptions options, std::shared_ptr<spdlog::logger> log)
    : m_store(store),
      m_executor(executor),
      m_policy(policy),
      m_options(std::move(options)),
      m_log(std::move(log)) {}

WebServer::~WebServer() {
  Stop();
}

void WebServer::Start() {
  if (!m_options.tls_cert.empty()) {
    auto tls =
        std::make_unique<httplib::SSLServer>(m_options.tls_cert.c_str(), m_options.tls_key.c_str());
    if (!tls->is_valid())
      throw std::runtime_error("http: cannot use tls_cert " + m_options.tls_cert +
                               " with tls_key " + m_options.tls_key);
    m_server = std::move(tls);
  } else {
    m_server = std::make_unique<httplib::Server>();
  }
  httplib::Server& server = *m_server;
  // Each request, an event stream for all its life, holds a thread: the streams' cap and
  // room for every other request.
  const int threads = m_options.max_streams + 16;
  server.new_task_queue = [threads] { return new httplib::ThreadPool(threads); };
  // One daemon per port: httplib would share it (SO_REUSEPORT) with a daemon already there.
  server.set_socket_options([](int socket) {
    int yes = 1;
    setsockopt(socket, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
  });
  server.set_read_timeout(5);
  server.set_write_timeout(5);
  server.set_keep_alive_timeout(5);
  server.set_payload_max_length(16 << 10);  // a login form; the API is read-only
  server.set_default_headers({
      {"Content-Security-Policy",
       "default-src 'self'; img-src 'self' data:; object-src 'none'; base-uri 'none'; "
       "form-action 'self'; frame-ancestors 'none'"},
      {"X-Content-Type-Options", "nosniff"},
      // (same-origin, not no-referrer: with none, a browser posts forms with "Origin: null")
      {"Referrer-Policy", "same-origin"},
      {"X-Frame-Options", "DENY"},
  });
  server.set_error_handler([](const Request& req, Response& res) {
    if (res.status == 404 && res.body.empty())
      SendRefusal(res, {404, "no such page: " + req.path.substr(0, 200)});
  });
  server.set_logger([this](const Request& req, const Response& res) {
    m_log->debug("web: {} {} {} from {}", req.method, req.path, res.status, req.remote_addr);
  });
  m_routes = std::make_unique<Routes>(m_store, m_executor, m_policy, m_options, m_log);
  m_routes->Install(server);

  const auto [host, port] = SplitAddress(m_options.listen);
  m_port =
      port == 0 ? server.bind_to_any_port(host) : (server.bind_to_port(host, port) ? port : -1);
  if (m_port <= 0)
    throw std::runtime_error("http: cannot listen on " + m_options.listen +
                             " (in use, or not an address of this machine)");
  m_listener = std::thread([&server] { server.listen_after_bind(); });
}

void WebServer::Stop() {
  if (!m_server) return;
  if (m_routes) m_routes->Stop();
  m_server->stop();
  if (m_listener.joinable()) m_listener.join();
  m_server.reset();
}

}  // namespace dembuf::server::web
