// Limits on the text inputs dembuf parses: scene files, the daemon's configuration and the
// scene text inside requests. They are checked by one linear pass before any parser sees the
// text, so that a hostile file costs linear time and bounded memory: the TOML library parses
// nesting recursively (20,000 nested arrays overflow the stack) and long arrays in quadratic
// time (40,000 elements took 4 s), and neither has a limit of its own.
#pragma once

#include <cstddef>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>
#include <string_view>

namespace dembuf {

/// A text input passed one of its limits. The message names the input, the line, what was
/// found and the limit.
class InputLimitError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct TomlLimits {
  std::size_t max_bytes = 1 << 20;  ///< the whole text (scene files are a few kB)
  int max_depth = 8;                ///< arrays and tables nested in each other
  std::size_t max_string = 4096;    ///< bytes in one string (a path is at most 4096)
  std::size_t max_array = 1024;     ///< elements of one array, entries of one inline table
  std::size_t max_keys = 1000;      ///< key = value pairs (a scene has 46 fields)
};

/// Checks TOML text against the limits without parsing it, and that it is UTF-8 (the parser
/// reads past the end of some invalid sequences). Throws InputLimitError naming `name` (e.g.
/// `scene file "e2.toml"`).
void CheckTomlText(std::string_view text, const std::string& name, const TomlLimits& limits = {});

/// Why `text` cannot be a name shown to people (a job's, a sweep's, a user's), "" when it can:
/// names are printed in tables and on terminals, so text that is not UTF-8, control
/// characters (C0, DEL and C1: U+009B starts a terminal escape) and the bidirectional controls
/// that reorder what is shown (U+061C, U+200E, U+200F, U+202A-U+202E, U+2066-U+2069) are
/// refused. Says what was found and where ("holds the control character U+009B (byte 4)").
std::string DisplayTextProblem(std::string_view text);

/// `text` with every byte that breaks UTF-8 and every character DisplayTextProblem refuses
/// replaced by '?': what a client prints of a server's names.
std::string PrintableText(std::string_view text);

/// The longest command line kept with a job as its provenance: the client cuts a longer one,
/// the daemon refuses it.
inline constexpr std::size_t kMaxCommandLineBytes = 4096;

/// The content of a regular file of at most `max_bytes`, read without reading more (a device
/// or a huge file is refused, not read). Throws InputLimitError naming `what` and the path.
std::string ReadBoundedFile(const std::string& path, std::size_t max_bytes,
                            const std::string& what);

/// The deepest JSON a summary, a failure note or an answer of a server may nest: dembuf's own
/// nest four deep. Deeper text is refused while it is parsed (a document 10,000 deep made the
/// recursive destructor and printer overflow the stack, and its re-indented copy grew as the
/// square of its depth).
inline constexpr int kMaxJsonDepth = 64;

/// Parses JSON text that came from outside (a cluster node's files, a server's answer): at most
/// `max_bytes` long and kMaxJsonDepth deep. Throws InputLimitError naming `what` for text past
/// either, or that is not JSON.
nlohmann::json ParseBoundedJson(std::string_view text, const std::string& what,
                                std::size_t max_bytes = std::size_t{16} << 20);

}  // namespace dembuf
