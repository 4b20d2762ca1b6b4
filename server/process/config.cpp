#include "process/config.h"

#include "dembuf/core/threads.h"

#include <spdlog/common.h>

#include <algorithm>
#include <charconv>
#include <map>
#include <sstream>
#include <stdexcept>
#include <thread>
#include <toml.hpp>
#include <variant>
#include <vector>

#include "access/auth.h"
#include "dembuf/study/text/text_limits.h"
#include "jobs/slurm.h"

namespace dembuf::server {

namespace {

// A configuration file is a page of settings: the scene files' limits, and 64 KiB.
TomlLimits ConfigLimits() {
  TomlLimits limits;
  limits.max_bytes = 64 << 10;
  return limits;
}

}  // namespace

void LoadConfigFile(const std::string& path, ServerConfig& config) {
  std::string text;
  try {
    text = ReadBoundedFile(path, ConfigLimits().max_bytes, "configuration");
  } catch (const InputLimitError& e) {
    throw ConfigError(e.what());
  }
  LoadConfigText(text, path, config);
}

namespace {

// Where a setting goes in ServerConfig.
using ConfigTarget = std::variant<std::string*, int*, bool*, double*, std::vector<std::string>*,
                                  std::map<std::string, std::string>*>;
using ConfigSetting = std::pair<std::string, ConfigTarget>;

// Every setting once: its key and where it goes. A key not here is refused.
std::vector<ConfigSetting> ConfigSettings(ServerConfig& config) {
  return {
      {"listen", &config.listen},
      {"db", &config.db},
      {"workers", &config.workers},
      {"threads_per_job", &config.threads_per_job},
      {"queue_limit", &config.queue_limit},
      {"max_sweep_jobs", &config.max_sweep_jobs},
      {"log_file", &config.log_file},
      {"log_level", &config.log_level},
      {"shutdown_grace_s", &config.shutdown_grace_s},
      {"storage_retry_s", &config.storage_retry_s},
      {"access", &config.access},
      {"tls_cert", &config.tls_cert},
      {"tls_key", &config.tls_key},
      {"quota_queued_jobs", &config.quota_queued_jobs},
      {"quota_stored_mb", &config.quota_stored_mb},
      {"quota_beads", &config.quota_beads},
      {"quota_steps", &config.quota_steps},
      {"quota_bead_steps", &config.quota_bead_steps},
      {"quota_samples", &config.quota_samples},
      {"quota_memory_mb", &config.quota_memory_mb},
      {"quota_output_mb", &config.quota_output_mb},
      {"max_watch_streams_per_user", &config.max_watch_streams_per_user},
      {"max_watch_streams", &config.max_watch_streams},
      {"max_fetch_streams_per_user", &config.max_fetch_streams_per_user},
      {"max_fetch_streams", &config.max_fetch_streams},
      {"stream_write_timeout_s", &config.stream_write_timeout_s},
      {"max_request_kb", &config.max_request_kb},
      {"max_bed_push_mb", &config.max_bed_push_mb},
      {"http", &config.http},
      {"http_max_streams_per_user", &config.http_max_streams_per_user},
      {"http_max_streams", &config.http_max_streams},
      {"notify_url_file", &config.notify_url_file},
      {"notify_mention", &config.notify_mention},
      {"executor", &config.executor},
      {"slurm.partition", &config.slurm.partition},
      {"slurm.account", &config.slurm.account},
      {"slurm.cpus_per_job", &config.slurm.cpus_per_job},
      {"slurm.mem_per_job_mb", &config.slurm.mem_per_job_mb},
      {"slurm.time_limit", &config.slurm.time_limit},
      {"slurm.extra_args", &config.slurm.extra_args},
      {"slurm.work_dir", &config.slurm.work_dir},
      {"slurm.dembuf", &config.slurm.dembuf},
      {"slurm.poll_s", &config.slurm.poll_s},
      {"slurm.array_tasks_max", &config.slurm.array_tasks_max},
      {"slurm.array_limit", &config.slurm.array_limit},
      {"slurm.accounts", &config.slurm.accounts},
      {"slurm.wckey", &config.slurm.wckey},
  };
}

}  // namespace

namespace {

// Sets each (key, value) through the table of settings; `origin` names where they came from
// in messages ("configuration /etc/dembuf/dembufd.toml", "--setting").
void ApplyEntries(const std::vector<std::pair<std::string, const toml::value*>>& entries,
                  const std::string& origin, ServerConfig& config) {
  const std::vector<ConfigSetting> settings = ConfigSettings(config);
  for (const auto& entry : entries) {
    // (Named references, not a structured binding: clang 14 cannot capture one.)
    const std::string& key = entry.first;
    const toml::value& value = *entry.second;
    const auto setting = std::find_if(settings.begin(), settings.end(),
                                      [&](const auto& s) { return s.first == key; });
    if (key == "require_tokens")
      throw ConfigError(origin +
                        ": require_tokens is replaced by access: \"tokens\" (the default: every "
                        "request on every address carries a token) or \"local\"");
    if (setting == settings.end()) throw ConfigError(origin + ": unknown setting \"" + key + "\"");
    if (key == "workers" && value.is_string()) {  // "auto", or a number
      config.workers = ParseWorkers(value.as_string());
      continue;
    }
    std::visit(
        [&](auto* target) {
          using T = std::remove_pointer_t<decltype(target)>;
          // Limits are numbers: 1000000, 1e6 and 1_000_000 all say the same.
          if constexpr (std::is_same_v<T, double>) {
            if (value.is_integer()) {
              *target = static_cast<double>(value.as_integer());
              return;
            }
          }
          try {
            *target = toml::get<T>(value);
          } catch (const std::exception&) {
            const char* wanted = std::is_same_v<T, std::string> ? "a string"
                                 : std::is_same_v<T, int>       ? "a whole number"
                                 : std::is_same_v<T, bool>      ? "true or false"
                                 : std::is_same_v<T, double>    ? "a number"
                                 : std::is_same_v<T, std::vector<std::string>>
                                     ? "a list of strings"
                                     : "a table of strings (name = \"value\")";
            throw ConfigError(origin + ": " + key + " has the wrong type: it takes " + wanted);
          }
        },
        setting->second);
  }
}

}  // namespace

void LoadConfigText(const std::string& text, const std::string& path, ServerConfig& config) {
  toml::value root;
  try {
    CheckTomlText(text, "configuration " + path, ConfigLimits());
    std::istringstream in(text);
    root = toml::parse(in, path);
  } catch (const InputLimitError& e) {
    throw ConfigError(e.what());
  } catch (const std::exception& e) {
    throw ConfigError("configuration " + path + ": " + e.what());
  }
  // The settings with their tables' names: [slurm] work_dir = ... is "slurm.work_dir".
  std::vector<std::pair<std::string, const toml::value*>> entries;
  for (const auto& [key, value] : root.as_table()) {
    if (key == "slurm" && value.is_table()) {
      for (const auto& [inner, inner_value] : value.as_table())
        entries.push_back({"slurm." + inner, &inner_value});
    } else {
      entries.push_back({key, &value});
    }
  }
  ApplyEntries(entries, "configuration " + path, config);
}

void ApplySettingFlag(const std::string& assignment, ServerConfig& config) {
  const std::size_t eq = assignment.find('=');
  const std::string origin = "--setting " + assignment.substr(0, std::min<std::size_t>(eq, 64));
  if (eq == std::string::npos || eq == 0)
    throw ConfigError(origin +
                      ": give KEY=VALUE, a key of the configuration file (slurm.KEY "
                      "for its [slurm] table), as in --setting quota_beads=2e6");
  const std::string key = assignment.substr(0, eq), text = assignment.substr(eq + 1);
  if (std::any_of(text.begin(), text.end(), [](unsigned char c) { return c < 0x20 || c == 0x7f; }))
    throw ConfigError(origin + ": the value has a control character");
  // The value as the file would write it (2e6, true, ["--qos=x"], "text"); text that is not a
  // TOML value is the text itself: --setting slurm.partition=debug.
  toml::value value;
  try {
    const std::string line = "v = " + text;
    CheckTomlText(line, origin, ConfigLimits());
    std::istringstream in(line);
    const toml::value parsed = toml::parse(in, "--setting");
    if (parsed.as_table().size() != 1) throw std::invalid_argument("one value");
    value = parsed.as_table().at("v");
  } catch (const std::exception&) {
    value = toml::value(text);
  }
  ApplyEntries({{key, &value}}, origin, config);
}

namespace {

// A setting's value as the configuration file writes it, on one line: a table inline
// (toml11 writes a table as the root of a file).
std::string SettingText(const ConfigTarget& target) {
  return std::visit(
      [](auto* v) -> std::string {
        using T = std::remove_pointer_t<decltype(v)>;
        if constexpr (std::is_same_v<T, std::map<std::string, std::string>>) {
          std::string text;
          for (const auto& [name, value] : *v)
            text += (text.empty() ? "" : ", ") + toml::format_key(name) + " = " +
                    toml::format(toml::value(value));
          return "{" + text + "}";
        } else {
          return toml::format(toml::value(*v));
        }
      },
      target);
}

}  // namespace

std::string ConfigText(const ServerConfig& resolved) {
  ServerConfig config = resolved;  // the table points into a config it may change
  std::string top, slurm;
  for (const auto& [key, target] : ConfigSettings(config)) {
    const bool in_slurm = key.rfind("slurm.", 0) == 0;
    (in_slurm ? slurm : top) +=
        (in_slurm ? key.substr(6) : key) + " = " + SettingText(target) + "\n";
  }
  return top + "\n[slurm]\n" + slurm;
}

int ParseWorkers(const std::string& text) {
  if (text == "auto") return kAutoWorkers;
  int workers = 0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), workers);
  if (error != std::errc() || end != text.data() + text.size() || workers < 1 || workers > 256)
    throw ConfigError("workers: \"" + text +
                      "\" is not a number of workers: 1 to 256, or \"auto\" (one per usable CPU)");
  return workers;
}

int ListenPort(const std::string& listen) {
  if (listen.rfind("unix:", 0) == 0 && listen.size() > 5) return -1;
  const auto colon = listen.rfind(':');
  const std::string port = colon == std::string::npos ? "" : listen.substr(colon + 1);
  const bool digits = !port.empty() && port.size() <= 9 &&
                      port.find_first_not_of("0123456789") == std::string::npos;
  if (colon == 0 || colon == std::string::npos || !digits)
    throw ConfigError("listen: \"" + listen +
                      "\" must be HOST:PORT (such as 127.0.0.1:50051 or [::1]:50051) or "
                      "unix:PATH");
  const int value = std::stoi(port);
  if (value > 65535)
    throw ConfigError("listen: port " + port +
                      " is out of range: must be 0 to 65535 (0: any free "
                      "port)");
  return value;
}

std::string HttpAddress(const std::string& http) {
  const bool port_alone = !http.empty() && http.size() <= 5 &&
                          http.find_first_not_of("0123456789") == std::string::npos;
  const std::string address = port_alone ? "127.0.0.1:" + http : http;
  const auto colon = address.rfind(':');
  const std::string port = colon == std::string::npos ? "" : address.substr(colon + 1);
  const bool digits = !port.empty() && port.size() <= 5 &&
                      port.find_first_not_of("0123456789") == std::string::npos;
  if (colon == 0 || colon == std::string::npos || !digits || std::stoi(port) > 65535)
    throw ConfigError("http: \"" + http +
                      "\" must be HOST:PORT (such as 127.0.0.1:8080 or 0.0.0.0:8080) or a port "
                      "0 to 65535 alone (on loopback; 0: any free port)");
  return address;
}

namespace {

// The [slurm] table of a daemon that runs its jobs on a cluster.
void ValidateSlurmConfig(const slurm::Settings& slurm) {
  auto require = [](bool ok, const std::string& what) {
    if (!ok) throw ConfigError(what);
  };
  require(!slurm.work_dir.empty(),
          "slurm.work_dir: give a folder every node of the cluster sees (jobs, beds, results)");
  require(slurm.cpus_per_job >= 1 && slurm.cpus_per_job <= 1024,
          "slurm.cpus_per_job: must be 1 to 1024, not " + std::to_string(slurm.cpus_per_job));
  require(slurm.mem_per_job_mb >= 0 && slurm.mem_per_job_mb <= 16 << 20,
          "slurm.mem_per_job_mb: must be 0 (from the estimate) to 16777216, not " +
              std::to_string(slurm.mem_per_job_mb));
  require(slurm.time_limit.empty() || slurm::ParseTimeLimit(slurm.time_limit),
          "slurm.time_limit: \"" + slurm.time_limit +
              "\" is not a Slurm time (MM, MM:SS, HH:MM:SS, D-HH, D-HH:MM, D-HH:MM:SS; at "
              "most a year) or \"\" (from the estimate)");
  require(slurm.poll_s >= 0.1 && slurm.poll_s <= 600,
          "slurm.poll_s: must be 0.1 to 600, not " + std::to_string(slurm.poll_s));
  // Names and values reach sbatch as single arguments, never through a shell; still, a
  // partition or account is one word of Slurm's.
  const auto slurm_name = [&](const std::string& name, const std::string& value) {
    require(value.find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ"
                                    "0123456789_-.,") == std::string::npos,
            name + ": \"" + value + "\" is not a Slurm name (letters, digits, _ - . and commas)");
  };
  slurm_name("slurm.partition", slurm.partition);
  slurm_name("slurm.account", slurm.account);
  for (const auto& [user, account] : slurm.accounts) {
    const std::string problem = UserNameProblem(user);
    require(problem.empty(), "slurm.accounts: the user " + problem);
    require(!account.empty(), "slurm.accounts." + user + ": give a Slurm account");
    slurm_name("slurm.accounts." + user, account);
  }
  require(slurm.array_tasks_max >= 1 && slurm.array_tasks_max <= 100000,
          "slurm.array_tasks_max: must be 1 (a Slurm job per dembuf job) to 100000, not " +
              std::to_string(slurm.array_tasks_max));
  require(slurm.array_limit >= 0 && slurm.array_limit <= 100000,
          "slurm.array_limit: must be 0 (no limit) to 100000, not " +
              std::to_string(slurm.array_limit));
  for (const std::string& arg : slurm.extra_args) {
    require(arg.rfind("--", 0) == 0 && arg.find('\n') == std::string::npos &&
                arg.rfind("--wrap", 0) != 0,
            "slurm.extra_args: \"" + arg +
                "\" must be one sbatch option, written --name=value (not --wrap)");
    // What the daemon sets itself for each job, which an extra argument after it would undo.
    const std::string name = arg.substr(0, arg.find('='));
    for (const char* own : {"--account", "--comment", "--wckey", "--array", "--job-name",
                            "--output", "--chdir", "--dependency", "--export"})
      require(name != own, "slurm.extra_args: \"" + arg + "\": " + own +
                               " is the daemon's to set for each job (accounts: [slurm.accounts])");
  }
}

}  // namespace

void ValidateConfig(ServerConfig& config) {
  auto require = [](bool ok, const std::string& what) {
    if (!ok) throw ConfigError(what);
  };
  ListenPort(config.listen);
  require(!config.db.empty(), "db: give a database file");
  require(config.workers >= 0 && config.workers <= 256,
          "workers: " + std::to_string(config.workers) + " is out of range: 1 to 256, or \"auto\"");
  require(config.threads_per_job >= 0 && config.threads_per_job <= 256,
          "threads_per_job: must be 0 (automatic) to 256");
  require(config.queue_limit >= 1 && config.queue_limit <= 1000000,
          "queue_limit: must be 1 to 1000000");
  require(config.max_sweep_jobs >= 1 && config.max_sweep_jobs <= 1000000,
          "max_sweep_jobs: must be 1 to 1000000");
  require(config.shutdown_grace_s >= 0 && config.shutdown_grace_s <= 86400,
          "shutdown_grace_s: must be 0 to 86400");
  require(config.storage_retry_s >= 1 && config.storage_retry_s <= 86400,
          "storage_retry_s: must be 1 to 86400");
  require(
      spdlog::level::from_str(config.log_level) != spdlog::level::off || config.log_level == "off",
      "log_level: must be trace, debug, info, warn, error, critical or off");
  require(config.tls_cert.empty() == config.tls_key.empty(),
          "tls_cert and tls_key: give both (or neither)");
  // (A quota above queue_limit is no error: the queue's own limit applies first.)
  require(config.quota_queued_jobs >= 0, "quota_queued_jobs: must be 0 (no limit) or more, not " +
                                             std::to_string(config.quota_queued_jobs));
  require(config.quota_stored_mb >= 0 && config.quota_stored_mb <= 1e12,
          "quota_stored_mb: must be 0 (no limit) to 1e12, not " +
              std::to_string(config.quota_stored_mb));
  // A cap on streams in all, up to `most`, and one per user within it.
  auto require_caps = [&](const std::string& total_name, int total, int most,
                          const std::string& per_user_name, int per_user) {
    require(total >= 1 && total <= most, total_name + ": must be 1 to " + std::to_string(most) +
                                             ", not " + std::to_string(total));
    require(per_user >= 1 && per_user <= total, per_user_name + ": must be 1 to " + total_name +
                                                    " (" + std::to_string(total) + "), not " +
                                                    std::to_string(per_user));
  };
  require_caps("max_watch_streams", config.max_watch_streams, 100000, "max_watch_streams_per_user",
               config.max_watch_streams_per_user);
  require_caps("max_fetch_streams", config.max_fetch_streams, 10000, "max_fetch_streams_per_user",
               config.max_fetch_streams_per_user);
  require(config.stream_write_timeout_s >= 1 && config.stream_write_timeout_s <= 3600,
          "stream_write_timeout_s: must be 1 to 3600, not " +
              std::to_string(config.stream_write_timeout_s));
  require(config.max_request_kb >= 16 && config.max_request_kb <= 1 << 20,
          "max_request_kb: must be 16 to 1048576");
  require(config.max_bed_push_mb >= 1 && config.max_bed_push_mb <= 4096,
          "max_bed_push_mb: must be 1 to 4096, not " + std::to_string(config.max_bed_push_mb));
  if (!config.http.empty()) config.http = HttpAddress(config.http);
  require(config.access == "tokens" || config.access == "local",
          "access: \"" + config.access + "\" must be \"tokens\" or \"local\"");
  // Without tokens, whoever reaches an address is an admin: only this machine may reach it.
  if (config.access == "local") {
    require(IsLoopback(config.listen),
            "access: \"local\" lets any caller act as an admin, so listen must be a loopback "
            "address or unix:PATH, not \"" +
                config.listen + "\" (use access = \"tokens\")");
    require(config.http.empty() || IsLoopback(config.http),
            "access: \"local\" lets any caller act as an admin, so http must be on loopback, "
            "not \"" +
                config.http + "\" (use access = \"tokens\")");
  }
  require_caps("http_max_streams", config.http_max_streams, 10000, "http_max_streams_per_user",
               config.http_max_streams_per_user);
  for (const auto& [name, value] : {std::pair{"quota_beads", config.quota_beads},
                                    {"quota_steps", config.quota_steps},
                                    {"quota_bead_steps", config.quota_bead_steps},
                                    {"quota_samples", config.quota_samples},
                                    {"quota_memory_mb", config.quota_memory_mb},
                                    {"quota_output_mb", config.quota_output_mb}})
    require(value >= 0 && value <= 1e18,
            std::string(name) + ": must be 0 (no limit) to 1e18, not " + std::to_string(value));
  require(config.executor == "threads" || config.executor == "slurm",
          "executor: \"" + config.executor + "\" must be \"threads\" or \"slurm\"");
  if (config.executor == "slurm") ValidateSlurmConfig(config.slurm);
  if (config.workers == kAutoWorkers) config.workers = std::min(256, dem::UsableCpus());
  if (config.threads_per_job == 0) {
    config.threads_per_job = std::max(1, dem::UsableCpus() / config.workers);
  }
}

}  // namespace dembuf::server
