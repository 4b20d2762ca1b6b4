#include "dembuf/study/text/text_limits.h"

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <vector>

namespace dembuf {

namespace {

// The code point at byte `i` of `text` and its length in bytes, or a length of 0 where the
// bytes there break UTF-8 (overlong forms and surrogates included).
std::size_t DecodeUtf8(std::string_view text, std::size_t i, unsigned* code) {
  const auto* p = reinterpret_cast<const unsigned char*>(text.data());
  const unsigned c = p[i];
  std::size_t len = 0;
  unsigned min = 0;
  if (c < 0x80) {
    *code = c;
    return 1;
  } else if ((c & 0xE0) == 0xC0) {
    len = 2;
    min = 0x80;
  } else if ((c & 0xF0) == 0xE0) {
    len = 3;
    min = 0x800;
  } else if ((c & 0xF8) == 0xF0) {
    len = 4;
    min = 0x10000;
  } else {
    return 0;
  }
  if (i + len > text.size()) return 0;
  *code = c & (0x7F >> len);
  for (std::size_t k = 1; k < len; ++k) {
    if ((p[i + k] & 0xC0) != 0x80) return 0;
    *code = (*code << 6) | (p[i + k] & 0x3F);
  }
  if (*code < min || *code > 0x10FFFF || (*code >= 0xD800 && *code <= 0xDFFF)) return 0;
  return len;
}

// The byte offset of the first byte that breaks UTF-8, or npos. TOML is UTF-8; the TOML
// parser must never see anything else (it reads past the end of some invalid sequences).
std::size_t FirstInvalidUtf8(std::string_view text) {
  unsigned code = 0;
  for (std::size_t i = 0; i < text.size();) {
    const std::size_t len = DecodeUtf8(text, i, &code);
    if (len == 0) return i;
    i += len;
  }
  return std::string::npos;
}

std::string Bytes(std::size_t n) {
  return std::to_string(n) + (n == 1 ? " byte" : " bytes");
}

// One pass over TOML's lexical structure: comments, the four kinds of string, and the
// brackets and braces outside them. Everything else (numbers, keys, dates) is left to the
// parser, which sees the text only after this pass has bounded it.
class TomlScanner {
 public:
  TomlScanner(std::string_view text, const std::string& name, const TomlLimits& limits)
      : m_text(text), m_name(name), m_limits(limits) {}

  void Run() {
    if (m_text.size() > m_limits.max_bytes)
      Fail(Bytes(m_text.size()) + "; at most " + Bytes(m_limits.max_bytes), false);
    while (m_at < m_text.size()) {
      const char c = m_text[m_at];
      switch (c) {
        case '\n':
          ++m_line;
          ++m_at;
          break;
        case '#':
          while (m_at < m_text.size() && m_text[m_at] != '\n') ++m_at;
          break;
        case '"':
        case '\'':
          String(c);
          break;
        case '[':
        case '{':
          if (static_cast<int>(m_elements.size()) >= m_limits.max_depth)
            Fail("arrays and tables nested more than " + std::to_string(m_limits.max_depth) +
                 " deep; at most " + std::to_string(m_limits.max_depth));
          m_elements.push_back(1);
          ++m_at;
          break;
        case ']':
        case '}':
          if (!m_elements.empty()) m_elements.pop_back();
          ++m_at;
          break;
        case ',':
          if (!m_elements.empty() && ++m_elements.back() > m_limits.max_array)
            Fail("an array or inline table with more than " + std::to_string(m_limits.max_array) +
                 " elements; at most " + std::to_string(m_limits.max_array));
          ++m_at;
          break;
        case '=':
          if (++m_keys > m_limits.max_keys)
            Fail("more than " + std::to_string(m_limits.max_keys) + " key = value pairs; at most " +
                 std::to_string(m_limits.max_keys));
          ++m_at;
          break;
        default:
          ++m_at;
      }
    }
  }

 private:
  [[noreturn]] void Fail(const std::string& what, bool with_line = true) const {
    throw InputLimitError(m_name + (with_line ? ": line " + std::to_string(m_line) : "") + ": " +
                          what);
  }

  // A string starting at m_at with quote q: "...", '...', """...""" or '''...'''. An
  // unterminated string ends the scan; the parser reports it.
  void String(char q) {
    const std::size_t start_line = m_line;
    const bool multi = m_text.substr(m_at, 3) == std::string(3, q);
    m_at += multi ? 3 : 1;
    const std::size_t begin = m_at;
    while (m_at < m_text.size()) {
      const char c = m_text[m_at];
      if (c == '\\' && q == '"') {  // an escape: the next byte is part of the string
        if (m_at + 1 < m_text.size() && m_text[m_at + 1] == '\n') ++m_line;
        m_at += 2;
        continue;
      }
      if (c == '\n') {
        if (!multi) break;
        ++m_line;
      }
      if (c == q && (!multi || m_text.substr(m_at, 3) == std::string(3, q))) {
        CheckLength(m_at - begin, start_line);
        // A closing """ may follow up to two quotes that belong to the string.
        std::size_t run = 0;
        while (m_at + run < m_text.size() && m_text[m_at + run] == q) ++run;
        m_at += multi ? run : 1;
        return;
      }
      ++m_at;
    }
    CheckLength(m_at - begin, start_line);
  }

  void CheckLength(std::size_t length, std::size_t line) const {
    if (length > m_limits.max_string)
      throw InputLimitError(m_name + ": line " + std::to_string(line) + ": a string of " +
                            Bytes(length) + "; at most " + Bytes(m_limits.max_string));
  }

  std::string_view m_text;
  const std::string& m_name;
  const TomlLimits& m_limits;
  std::size_t m_at = 0;
  std::size_t m_line = 1;
  std::size_t m_keys = 0;
  std::vector<std::size_t> m_elements;  // elements so far of each open array or table
};

}  // namespace

void CheckTomlText(std::string_view text, const std::string& name, const TomlLimits& limits) {
  if (text.size() <= limits.max_bytes)
    if (const std::size_t bad = FirstInvalidUtf8(text); bad != std::string::npos)
      throw InputLimitError(name + " is not UTF-8 text (invalid byte at offset " +
                            std::to_string(bad) + ")");
  TomlScanner(text, name, limits).Run();
}

namespace {

bool IsHiddenCode(unsigned code) {
  return code < 0x20 || (code >= 0x7F && code <= 0x9F) || code == 0x061C || code == 0x200E ||
         code == 0x200F || (code >= 0x202A && code <= 0x202E) || (code >= 0x2066 && code <= 0x2069);
}

}  // namespace

std::string PrintableText(std::string_view text) {
  std::string out;
  unsigned code = 0;
  for (std::size_t i = 0; i < text.size();) {
    const std::size_t len = DecodeUtf8(text, i, &code);
    if (len == 0 || IsHiddenCode(code)) {
      out += '?';
      i += len == 0 ? 1 : len;
    } else {
      out.append(text.substr(i, len));
      i += len;
    }
  }
  return out;
}

std::string DisplayTextProblem(std::string_view text) {
  unsigned code = 0;
  for (std::size_t i = 0; i < text.size();) {
    const std::size_t len = DecodeUtf8(text, i, &code);
    char where[96];
    if (len == 0) {
      std::snprintf(where, sizeof where, "is not UTF-8 (byte %zu)", i + 1);
      return where;
    }
    const bool control = code < 0x20 || (code >= 0x7F && code <= 0x9F);
    if (IsHiddenCode(code)) {
      std::snprintf(where, sizeof where, "holds %s U+%04X (byte %zu)",
                    control ? "the control character" : "the bidirectional control", code, i + 1);
      return where;
    }
    i += len;
  }
  return "";
}

std::string ReadBoundedFile(const std::string& path, std::size_t max_bytes,
                            const std::string& what) {
  std::error_code error;
  if (!std::filesystem::is_regular_file(path, error))
    throw InputLimitError(what + " \"" + path + "\" does not exist or is not a file");
  const auto size = std::filesystem::file_size(path, error);
  if (!error && size > max_bytes)
    throw InputLimitError(what + " \"" + path + "\" holds " + Bytes(size) + "; at most " +
                          Bytes(max_bytes));
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputLimitError(what + " \"" + path + "\" cannot be read");
  // Read in blocks until the end, or one byte past the limit: a file that grew since its size
  // was taken is refused too.
  std::string text;
  char block[1 << 16];
  while (in.read(block, sizeof block) || in.gcount() > 0) {
    text.append(block, static_cast<std::size_t>(in.gcount()));
    if (text.size() > max_bytes)
      throw InputLimitError(what + " \"" + path + "\" holds more than " + Bytes(max_bytes));
  }
  return text;
}

nlohmann::json ParseBoundedJson(std::string_view text, const std::string& what,
                                std::size_t max_bytes) {
  if (text.size() > max_bytes)
    throw InputLimitError(what + ": " + Bytes(text.size()) + ", more than the " + Bytes(max_bytes) +
                          " taken");
  // The parser reports each value's depth as it goes: the text is refused at the first
  // value too deep, before anything of it is built.
  const nlohmann::json::parser_callback_t within_depth =
      [&](int depth, nlohmann::json::parse_event_t, nlohmann::json&) {
        if (depth > kMaxJsonDepth)
          throw InputLimitError(what + ": nested deeper than " + std::to_string(kMaxJsonDepth) +
                                " levels");
        return true;
      };
  try {
    return nlohmann::json::parse(text.begin(), text.end(), within_depth);
  } catch (const nlohmann::json::exception& e) {
    throw InputLimitError(what + ": not JSON: " + e.what());
  }
}

}  // namespace dembuf
