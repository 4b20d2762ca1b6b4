#include "notify/notifier.h"

#include <httplib.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <nlohmann/json.hpp>
#include <stdexcept>

namespace dembuf::server {

HookAddress ParseHookUrl(const std::string& url) {
  const std::size_t scheme_end = url.find("://");
  const std::string scheme = url.substr(0, scheme_end);
  if (scheme_end == std::string::npos || (scheme != "http" && scheme != "https"))
    throw std::invalid_argument("the hook's URL must begin with https:// or http://");
  if (url.size() > 2048) throw std::invalid_argument("the hook's URL is longer than 2048 bytes");
  for (unsigned char c : url)
    if (c <= 0x20 || c >= 0x7f)
      throw std::invalid_argument("the hook's URL has a space, control or non-ASCII character");
  const std::size_t host_start = scheme_end + 3;
  const std::size_t path_start = url.find('/', host_start);
  HookAddress address;
  address.origin = url.substr(0, path_start);
  address.path = path_start == std::string::npos ? "/" : url.substr(path_start);
  const std::string host = address.origin.substr(host_start);
  // (user:password@ would be sent in the clear by some clients, and is not a hook's form.)
  if (host.empty() || host.find('@') != std::string::npos || host.find('?') != std::string::npos)
    throw std::invalid_argument("the hook's URL has no host, or one with user@ or ?");
  return address;
}

std::string ChatSafe(std::string_view text, std::size_t most) {
  std::string safe;
  for (unsigned char c : text.substr(0, most)) {
    const bool allowed =
        std::isalnum(c) ||
        std::string_view(" .,_-:/=()+%#").find(static_cast<char>(c)) != std::string_view::npos;
    safe += allowed ? static_cast<char>(c) : '?';
  }
  if (text.size() > most) safe += "...";
  // (A chat makes "scheme://..." a link: a name shows as text, not as the daemon's link.)
  for (std::size_t at; (at = safe.find("://")) != std::string::npos;) safe.replace(at, 3, ": //");
  return safe;
}

namespace {

std::string Whose(const std::string& owner, bool mention) {
  // An owner's name is [A-Za-z0-9._-], so "@name" mentions that user and no one else, but for
  // the names the chats keep for everyone in a channel.
  for (const char* everyone : {"channel", "all", "here", "everyone"})
    if (owner == everyone) return "";
  return mention ? "@" + ChatSafe(owner, 64) + " " : "";
}

std::string Newtons(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%.4g N", value);
  return text;
}

}  // namespace

std::string JobEndedText(const JobRecord& job, bool mention) {
  std::string text = Whose(job.owner, mention) + "dembuf: job " + std::to_string(job.id) + " \"" +
                     ChatSafe(job.name, 80) + "\" of " + ChatSafe(job.owner, 64) + " ";
  if (job.state == JobState::kDone) {
    text += "is done";
    // (P, the paper's measure: the peak force on the bottom plate)
    if (job.P_N && std::isfinite(*job.P_N)) text += ": P = " + Newtons(*job.P_N);
  } else {
    text += job.state == JobState::kCancelled ? "was cancelled" : "failed";
    if (!job.error.empty()) text += ": " + ChatSafe(job.error, 300);
  }
  return text + " (dembuf fetch " + std::to_string(job.id) + ")";
}

std::string SweepEndedText(const SweepRecord& sweep, const std::map<std::string, int>& by_state,
                           bool mention) {
  int total = 0;
  std::string counts;
  for (const char* state : {"done", "failed", "cancelled"}) {
    const auto it = by_state.find(state);
    const int n = it == by_state.end() ? 0 : it->second;
    total += n;
    if (n > 0) counts += (counts.empty() ? "" : ", ") + std::to_string(n) + " " + state;
  }
  return Whose(sweep.owner, mention) + "dembuf: sweep " + std::to_string(sweep.id) + " \"" +
         ChatSafe(sweep.name, 80) + "\" of " + ChatSafe(sweep.owner, 64) + " has ended: " + counts +
         " of " + std::to_string(total) + " jobs (dembuf fetch --sweep " +
         std::to_string(sweep.id) + ")";
}

std::string HookBody(const std::string& text) {
  return nlohmann::json{{"text", text}}.dump();
}

Notifier::Notifier(Store& store, NotifierOptions options, std::shared_ptr<spdlog::logger> log)
    : m_store(store),
      m_options(std::move(options)),
      m_hook(ParseHookUrl(m_options.url)),
      m_log(std::move(log)) {}

Notifier::~Notifier() {
  Shutdown();
}

void Notifier::Start() {
  m_log->info("notifications go to the hook at {} (the rest of its URL is secret)", m_hook.origin);
  if (m_hook.origin.rfind("http://", 0) == 0)
    m_log->warn(
        "the hook's URL is http: its secret crosses in clear text, and on loopback any account "
        "that takes the port while the chat is down receives it; use https");
  m_loop = std::jthread([this] { Loop(); });
}

void Notifier::Shutdown() {
  {
    std::lock_guard lock(m_mutex);
    m_stopping = true;
  }
  m_wake.notify_all();
  if (m_loop.joinable()) m_loop.join();
}

void Notifier::Loop() {
  const auto interval =
      std::chrono::milliseconds(static_cast<std::int64_t>(std::max(0.1, m_options.poll_s) * 1000));
  for (;;) {
    try {
      SendDue();
    } catch (const std::exception& e) {
      m_log->error("notifications: {}", e.what());  // the database, for now: the next pass
    }
    std::unique_lock lock(m_mutex);
    if (m_wake.wait_for(lock, interval, [&] { return m_stopping; })) return;
  }
}

std::string Notifier::TextOf(const NotificationRecord& due) {
  if (due.job_id != 0) {
    const std::optional<JobRecord> job = m_store.GetJob(due.job_id);
    return job ? JobEndedText(*job, m_options.mention) : "";
  }
  const std::optional<SweepRecord> sweep = m_store.GetSweep(due.sweep_id);
  return sweep ? SweepEndedText(*sweep, m_store.SweepStateCounts(sweep->id), m_options.mention)
               : "";
}

void Notifier::SendDue() {
  const auto now = std::chrono::steady_clock::now();
  for (const NotificationRecord& due : m_store.DueNotifications()) {
    {
      std::lock_guard lock(m_mutex);
      if (m_stopping) return;
    }
    Retry& retry = m_retries[due.id];
    if (retry.failures > 0 && now < retry.next) continue;
    const std::string what =
        due.job_id ? "job " + std::to_string(due.job_id) : "sweep " + std::to_string(due.sweep_id);
    const std::string text = TextOf(due);
    if (text.empty()) {
      m_store.EndNotification(due.id, "failed", what + " is gone");
      m_retries.erase(due.id);
      continue;
    }
    // Posted but not yet recorded (the database failed just after): not posted again.
    if (m_posted.count(due.id)) {
      m_store.EndNotification(due.id, "sent");
      m_posted.erase(due.id);
      continue;
    }
    const std::string error = Post(HookBody(text));
    if (error.empty()) {
      m_posted.insert(due.id);
      m_store.EndNotification(due.id, "sent");
      m_posted.erase(due.id);
      m_retries.erase(due.id);
      m_log->info("{} of {}: its end was posted to the hook", what, due.owner);
      continue;
    }
    ++retry.failures;
    if (retry.failures >= m_options.attempts) {
      m_store.EndNotification(due.id, "failed", error);
      m_retries.erase(due.id);
      m_log->error("{} of {}: the hook refused its end {} times, given up: {}", what, due.owner,
                   m_options.attempts, error);
      continue;
    }
    // 5 s, 10 s, 20 s, ... up to 10 min: a chat server that restarts is waited for, not
    // flooded.
    const double pause =
        std::min(600.0, m_options.first_pause_s * std::pow(2.0, retry.failures - 1));
    retry.next = now + std::chrono::milliseconds(static_cast<std::int64_t>(pause * 1000));
    m_log->warn("{} of {}: the hook did not take its end ({}); tried again in {} s", what,
                due.owner, error, pause);
  }
}

std::string Notifier::Post(const std::string& body) {
  httplib::Client client(m_hook.origin);
  client.set_connection_timeout(m_options.timeout);
  client.set_read_timeout(m_options.timeout);
  client.set_write_timeout(m_options.timeout);
  client.set_follow_location(false);  // the hook is where the administrator said, not elsewhere
  client.set_decompress(false);       // (a small compressed reply may inflate to gigabytes)
  // The reply is read to 4 kB at most, and within the timeout however slowly it comes.
  std::string reply;
  const auto deadline = std::chrono::steady_clock::now() + 2 * m_options.timeout;
  httplib::Request request;
  request.method = "POST";
  request.path = m_hook.path;
  request.body = body;
  request.set_header("Content-Type", "application/json");
  request.content_receiver = [&](const char* data, std::size_t size, std::uint64_t, std::uint64_t) {
    reply.append(data,
                 std::min(size, std::size_t{4096} - std::min(reply.size(), std::size_t{4096})));
    return std::chrono::steady_clock::now() < deadline;
  };
  httplib::Result result = client.send(request);
  if (!result) {
    switch (result.error()) {
      case httplib::Error::Connection:
        return "no answer: cannot connect";
      case httplib::Error::ConnectionTimeout:
        return "no answer: the connection timed out";
      case httplib::Error::Read:
        return "no answer: no reply in " + std::to_string(m_options.timeout.count()) + " s";
      case httplib::Error::Canceled:
        return "no answer: its reply took longer than " +
               std::to_string(2 * m_options.timeout.count()) + " s";
      case httplib::Error::SSLServerVerification:
        return "no answer: its TLS certificate is not one this machine trusts";
      default:
        return "no answer: " + httplib::to_string(result.error());
    }
  }
  if (result->status / 100 != 2)
    return "HTTP " + std::to_string(result->status) + ": " + ChatSafe(reply, 200);
  return "";
}

}  // namespace dembuf::server
