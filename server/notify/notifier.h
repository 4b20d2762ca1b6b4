// Telling users that their work has ended: a job or sweep submitted with `notify` is posted,
// once it has ended, to the chat hook the administrator configures (an incoming webhook of
// Mattermost or Slack: a POST of {"text": ...}). What is owed is in the database
// (store/notification_table.h), so a restart loses none; a hook that fails is tried again
// with growing pauses, then given up and logged. Users never choose the address: the daemon
// posts only where its administrator said.
#pragma once

#include <spdlog/logger.h>

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <string_view>
#include <thread>

#include "store/store.h"

namespace dembuf::server {

/// A hook's address in the parts an HTTP client takes: "https://chat.lab:8065" and
/// "/hooks/xyz".
struct HookAddress {
  std::string origin;
  std::string path;
};
/// Splits an http:// or https:// URL; throws std::invalid_argument saying what is wrong
/// (never repeating the URL, which is a secret: whoever has it may post).
HookAddress ParseHookUrl(const std::string& url);

/// Text of a user's (a job's name, an error) as a chat message may show it: only letters,
/// digits, spaces and . , _ - : / = ( ) + % # (so no @channel, <!here> or markdown), others
/// as '?', "://" broken (no link), at most `most` characters.
std::string ChatSafe(std::string_view text, std::size_t most = 200);

/// The message for a job of its own, once ended; `mention` puts "@owner " first.
std::string JobEndedText(const JobRecord& job, bool mention);
/// The message for a sweep whose jobs have all ended, with their count in each state.
std::string SweepEndedText(const SweepRecord& sweep, const std::map<std::string, int>& by_state,
                           bool mention);
/// The JSON body posted: {"text": text}.
std::string HookBody(const std::string& text);

struct NotifierOptions {
  std::string url;                   ///< the hook (from notify_url_file)
  bool mention = false;              ///< messages begin with "@owner"
  double poll_s = 2.0;               ///< how often the database is asked what has ended
  std::chrono::seconds timeout{10};  ///< a hook that takes longer has failed this time
  int attempts = 12;  ///< tries before a notification is given up (5 s ... 10 min apart)
  double first_pause_s = 5.0;
};

class Notifier {
 public:
  /// Throws std::invalid_argument for a URL that is not one (before the daemon serves).
  Notifier(Store& store, NotifierOptions options, std::shared_ptr<spdlog::logger> log);
  ~Notifier();
  void Start();
  /// Stops; what is still owed is sent by the next start.
  void Shutdown();

 private:
  void Loop();
  void SendDue();
  /// The message of a notification now due; "" when what it was about is gone.
  std::string TextOf(const NotificationRecord& due);
  /// Posts; "" when the hook took it, else why not.
  std::string Post(const std::string& body);

  Store& m_store;
  NotifierOptions m_options;
  HookAddress m_hook;
  std::shared_ptr<spdlog::logger> m_log;
  struct Retry {
    int failures = 0;
    std::chrono::steady_clock::time_point next;
  };
  std::map<std::int64_t, Retry> m_retries;  ///< (the loop's alone)
  std::set<std::int64_t> m_posted;          ///< posted, not yet recorded as sent
  std::mutex m_mutex;
  std::condition_variable m_wake;
  bool m_stopping = false;
  std::jthread m_loop;
};

}  // namespace dembuf::server
