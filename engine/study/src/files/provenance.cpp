#include "dembuf/study/files/provenance.h"

#include <omp.h>
#include <unistd.h>
#ifdef __GLIBC__
#include <gnu/libc-version.h>
#endif

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <ctime>
#include <sstream>
#include <stdexcept>

#include "dembuf/study/scene/scene_fields.h"
#include "dembuf/study/version.h"

namespace dembuf::report {

std::string UtcNow() {
  const std::time_t now = std::time(nullptr);
  std::tm utc{};
  gmtime_r(&now, &utc);
  char text[32];
  std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%SZ", &utc);
  return text;
}

std::string HostName() {
  char name[256] = {};
  if (gethostname(name, sizeof name - 1) != 0) return "";
  return name;
}

std::string ShellCommandLine(int argc, const char* const* argv) {
  // Words of safe characters stay bare; other printable ASCII goes in single quotes (each '
  // as '\''); a word with control or non-ASCII bytes is written $'...' with \xHH escapes. The
  // line is ASCII, so that it is valid UTF-8 whatever the arguments' bytes were.
  auto safe = [](unsigned char c) {
    return std::isalnum(c) ||
           std::string_view("%+,-./:=@_").find(static_cast<char>(c)) != std::string_view::npos;
  };
  auto printable = [](unsigned char c) { return c >= 0x20 && c < 0x7f; };
  std::string line;
  for (int i = 0; i < argc; ++i) {
    const std::string_view word = argv[i];
    if (i > 0) line += ' ';
    if (!word.empty() && std::all_of(word.begin(), word.end(), safe)) {
      line += word;
    } else if (std::all_of(word.begin(), word.end(), printable)) {
      line += '\'';
      for (char c : word) line += c == '\'' ? std::string("'\\''") : std::string(1, c);
      line += '\'';
    } else {
      line += "$'";
      for (unsigned char c : word) {
        char escaped[8];
        if (c == '\\' || c == '\'') {
          line += '\\';
          line += static_cast<char>(c);
        } else if (printable(c)) {
          line += static_cast<char>(c);
        } else {
          std::snprintf(escaped, sizeof escaped, "\\x%02x", c);
          line += escaped;
        }
      }
      line += '\'';
    }
  }
  return line;
}

std::string ShellCommandLine(int argc, const char* const* argv,
                             const std::vector<std::string>& secret_options) {
  std::vector<std::string> words(argv, argv + argc);
  for (std::size_t i = 0; i < words.size(); ++i) {
    for (const std::string& option : secret_options) {
      if (words[i] == option && i + 1 < words.size()) {
        words[++i] = "<hidden>";
        break;
      }
      if (words[i].rfind(option + "=", 0) == 0) {
        words[i] = option + "=<hidden>";
        break;
      }
    }
  }
  std::vector<const char*> pointers;
  for (const std::string& word : words) pointers.push_back(word.c_str());
  return ShellCommandLine(argc, pointers.data());
}

std::string WithoutSecrets(std::string line, const std::string& secret) {
  constexpr std::string_view kHidden = "<hidden>";
  if (!secret.empty())
    for (std::size_t at = line.find(secret); at != std::string::npos;
         at = line.find(secret, at + kHidden.size()))
      line.replace(at, secret.size(), kHidden);
  // The value after --token, up to the end of its word (a quoted word ends at its quote).
  constexpr std::string_view kOption = "--token";
  for (std::size_t at = line.find(kOption); at != std::string::npos;
       at = line.find(kOption, at + 1)) {
    std::size_t value = at + kOption.size();
    if (value >= line.size() || (line[value] != '=' && line[value] != ' ')) continue;
    ++value;
    if (line.compare(value, kHidden.size(), kHidden) == 0) continue;
    std::size_t end = value;
    if (end < line.size() && (line[end] == '\'' || line[end] == '$')) {
      end = line.find('\'', line[end] == '$' ? end + 2 : end + 1);
      end = end == std::string::npos ? line.size() : end + 1;
    } else {
      end = std::min(line.find(' ', value), line.size());
    }
    line.replace(value, end - value, kHidden);
  }
  return line;
}

RunContext RunStartingNow(std::string command_line) {
  return {std::move(command_line), HostName(), UtcNow(), "", omp_get_max_threads(), {}};
}

std::string LibcVersion() {
#ifdef __GLIBC__
  return std::string("glibc ") + gnu_get_libc_version();
#else
  return "unknown";
#endif
}

std::string SceneText(const Scene& scene) {
  std::ostringstream text;
  PrintScene(scene, text);
  return text.str();
}

namespace {

// Whether compile flags leave the target to the machine that builds (-march=native): two
// such builds on different processors name the same configuration.
bool NamesNoTarget(std::string_view config) {
  return config.find("=native") != std::string_view::npos;
}

// The summary's provenance, or null.
const nlohmann::json* ProvenanceOf(const nlohmann::json& summary) {
  if (!summary.is_object()) return nullptr;
  const auto it = summary.find("provenance");
  return it != summary.end() && it->is_object() ? &*it : nullptr;
}

std::string Text(const nlohmann::json& object, const char* key) {
  const auto it = object.find(key);
  return it != object.end() && it->is_string() ? it->get<std::string>() : "";
}

}  // namespace

bool MadeByThisEngine(const nlohmann::json& summary, BuildMatch match) {
  const nlohmann::json* p = ProvenanceOf(summary);
  if (!p) return false;
  const bool same = Text(*p, "dembuf_version") == kVersion &&
                    Text(*p, "build_commit") == BuildCommit() &&
                    Text(*p, "build_type") == BuildType() &&
                    Text(*p, "build_config") == BuildConfig() && Text(*p, "libc") == LibcVersion();
  if (match == BuildMatch::kSameNames) return same;
  return same && std::string_view(BuildCommit()) != "unknown" && LibcVersion() != "unknown" &&
         !NamesNoTarget(BuildConfig());
}

bool RanScene(const nlohmann::json& summary, const std::string& scene_text) {
  const nlohmann::json* p = ProvenanceOf(summary);
  return p && Text(*p, "scene_sha256") == Sha256Hex(scene_text);
}

nlohmann::json ProvenanceJson(const RunContext& run, const Scene& scene, const BedSummary& bed) {
  return {
      {"dembuf_version", kVersion},
      {"build_commit", BuildCommit()},
      {"build_type", BuildType()},
      {"build_config", BuildConfig()},
      {"libc", LibcVersion()},
      {"scene_sha256", Sha256Hex(SceneText(scene))},
      {"bed_hash", bed.hash},
      {"bed_sha256", bed.sha256},
      {"seed", scene.bed.seed},
      {"threads", run.threads},
      {"host", run.host},
      {"started_at", run.started_at},
      {"finished_at", run.finished_at},
      {"command_line", run.command_line},
      {"model_reference", kPaperReference},
      {"timeline", run.timeline},
  };
}

}  // namespace dembuf::report
