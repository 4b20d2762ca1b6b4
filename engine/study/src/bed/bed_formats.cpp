#include "dembuf/study/bed/bed_formats.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <map>
#include <optional>
#include <sstream>

#include "dembuf/study/scene/errors.h"

namespace dembuf {

const char* BedFileFormatName(BedFileFormat format) {
  switch (format) {
    case BedFileFormat::kLammpsData:
      return "LAMMPS data";
    case BedFileFormat::kLammpsDump:
      return "LAMMPS dump";
    case BedFileFormat::kText:
      break;
  }
  return "text";
}

double MetresPerUnit(const std::string& unit) {
  static const std::map<std::string, double> units = {
      {"m", 1.0}, {"cm", 1e-2}, {"mm", 1e-3}, {"um", 1e-6}};
  const auto it = units.find(unit);
  return it == units.end() ? 0.0 : it->second;
}

namespace {

// The file's lines one at a time, bounded as bed_io.h says, with its first lines kept for
// telling the format (a bed file may be half a gigabyte: it is never held whole).
class Lines {
 public:
  static constexpr std::size_t kLookahead = 64;

  Lines(std::istream& in, std::string name) : m_in(in), m_name(std::move(name)) {
    std::string line;
    while (m_head.size() < kLookahead && ReadRaw(line)) m_head.push_back(line);
  }
  // The first lines, for telling the format.
  const std::vector<std::string>& head() const { return m_head; }
  // The next line (its number in number()); false at the end.
  bool Next(std::string& line) {
    if (m_next < m_head.size()) {
      line = m_head[m_next++];
    } else if (!ReadRaw(line)) {
      return false;
    }
    ++m_number;
    return true;
  }
  long number() const { return m_number; }
  [[noreturn]] void Fail(const std::string& why) const { Fail(m_number, why); }
  [[noreturn]] void Fail(long line, const std::string& why) const {
    throw SceneError("bed.import", m_name + ":" + std::to_string(line) + ": " + why);
  }

 private:
  bool ReadRaw(std::string& line) {
    if (m_in.getline(m_buf.data(), static_cast<std::streamsize>(m_buf.size() - 1))) {
      line.assign(m_buf.data());
      ++m_read;
      return true;
    }
    if (m_in.eof()) {  // the last line may lack its newline
      line.assign(m_buf.data());
      m_read += m_in.gcount() > 0;
      return m_in.gcount() > 0;
    }
    Fail(m_read + 1, "a line longer than " + std::to_string(kMaxBedLineBytes) + " bytes");
  }

  std::istream& m_in;
  std::string m_name;
  std::vector<char> m_buf = std::vector<char>(kMaxBedLineBytes + 2);
  std::vector<std::string> m_head;
  std::size_t m_next = 0;
  long m_number = 0;
  long m_read = 0;
};

// A line without its comment ('#' on), and the comment's first word.
std::string Uncommented(const std::string& line) {
  return line.substr(0, line.find('#'));
}
std::string CommentWord(const std::string& line) {
  const std::size_t hash = line.find('#');
  if (hash == std::string::npos) return "";
  std::istringstream rest(line.substr(hash + 1));
  std::string word;
  rest >> word;
  return word;
}

std::vector<std::string> Words(const std::string& text) {
  std::istringstream in(text);
  std::vector<std::string> words;
  for (std::string w; in >> w;) words.push_back(w);
  return words;
}

std::optional<double> Number(const std::string& word) {
  double value = 0.0;
  const auto [end, error] = std::from_chars(word.data(), word.data() + word.size(), value);
  if (error != std::errc() || end != word.data() + word.size()) return std::nullopt;
  return value;
}

std::string Shown(const std::string& word) {
  return "\"" + word.substr(0, 40) + "\"";
}

// ---- plain text ------------------------------------------------------------------------------

// A text header's column: its quantity and its unit ("x_mm", "r[mm]", "diameter", ...).
struct Column {
  std::string quantity;  // x, y, z, radius or diameter; "" for a column not read
  double metres = 0.0;   // per unit; 0: the file's unit
};

Column ParseColumn(const std::string& word, const Lines& lines) {
  std::string name = word, unit;
  if (const auto open = name.find('['); open != std::string::npos && name.back() == ']') {
    unit = name.substr(open + 1, name.size() - open - 2);
    name.erase(open);
  } else if (const auto bar = name.rfind('_'); bar != std::string::npos) {
    unit = name.substr(bar + 1);
    name.erase(bar);
  }
  std::transform(name.begin(), name.end(), name.begin(),
                 [](unsigned char c) { return std::tolower(c); });
  static const std::map<std::string, std::string> quantities = {{"x", "x"},
                                                                {"y", "y"},
                                                                {"z", "z"},
                                                                {"r", "radius"},
                                                                {"radius", "radius"},
                                                                {"d", "diameter"},
                                                                {"diameter", "diameter"},
                                                                {"type", "type"},
                                                                {"species", "type"}};
  Column column;
  const auto it = quantities.find(name);
  if (it == quantities.end()) return column;  // another column (id, type, ...): not read
  column.quantity = it->second;
  if (column.quantity == "type") {
    if (!unit.empty()) lines.Fail("column " + Shown(word) + ": a type has no unit");
    return column;
  }
  if (!unit.empty()) {
    column.metres = MetresPerUnit(unit);
    if (column.metres == 0.0)
      lines.Fail("column " + Shown(word) + ": unit " + Shown(unit) + " is none of m, cm, mm, um");
  }
  return column;
}

std::vector<BeadRecord> ReadText(Lines& lines, double metres, double max_beads) {
  std::vector<Column> columns = {{"x", 0}, {"y", 0}, {"z", 0}, {"radius", 0}};
  bool header_seen = false, data_seen = false;
  std::vector<BeadRecord> beads;
  for (std::string raw; lines.Next(raw);) {
    const std::string text = Uncommented(raw);
    const std::vector<std::string> words = Words(text);
    if (words.empty()) continue;
    if (!Number(words[0])) {
      // A header: the first line that is not a comment, before any bead.
      if (header_seen || data_seen)
        lines.Fail(
            "expected four numbers: x y z radius (a header naming the columns may only "
            "come first)");
      header_seen = true;
      columns.clear();
      std::map<std::string, int> named;
      for (const std::string& w : words) {
        columns.push_back(ParseColumn(w, lines));
        ++named[columns.back().quantity];
      }
      if (!named["x"] || !named["y"] || !named["z"] || named["radius"] + named["diameter"] != 1 ||
          named["type"] > 1)
        lines.Fail(
            "a header names the columns x, y, z and one of r (radius) or d (diameter), "
            "units as x_mm or x[mm] (m, cm, mm, um), and at most one type (or species); got " +
            Shown(text));
      continue;
    }
    data_seen = true;
    if (words.size() != columns.size())
      lines.Fail("expected " + std::to_string(columns.size()) + " numbers: " +
                 (header_seen ? std::string("the header's columns") : "x y z radius") +
                 (words.size() > columns.size()
                      ? "; unexpected text " + Shown(words[columns.size()]) + " after them"
                      : ""));
    BeadRecord bead;
    bead.line = lines.number();
    for (std::size_t c = 0; c < columns.size(); ++c) {
      const std::optional<double> value = Number(words[c]);
      if (!value) lines.Fail("not a number: " + Shown(words[c]));
      const std::string& q = columns[c].quantity;
      if (q == "type") {
        bead.type = *value;
        continue;
      }
      const double v = *value * (columns[c].metres > 0 ? columns[c].metres : metres);
      if (q == "x") bead.x = v;
      if (q == "y") bead.y = v;
      if (q == "z") bead.z = v;
      if (q == "radius") bead.radius = v;
      if (q == "diameter") bead.radius = 0.5 * v;
    }
    if (static_cast<double>(beads.size()) >= max_beads)
      lines.Fail("more beads than a simulation can hold");
    beads.push_back(bead);
  }
  return beads;
}

// ---- LAMMPS data files -----------------------------------------------------------------------

// The section keywords of a LAMMPS data file.
bool IsSectionKeyword(const std::string& word) {
  static const char* const keywords[] = {
      "Atoms", "Velocities", "Masses",    "Ellipsoids", "Lines",  "Triangles", "Bodies",
      "Bonds", "Angles",     "Dihedrals", "Impropers",  "PairIJ", "Pair"};
  return std::find_if(std::begin(keywords), std::end(keywords),
                      [&](const char* k) { return word == k; }) != std::end(keywords);
}

bool LooksLikeLammpsData(const std::vector<std::string>& head) {
  // After the title line, a header line "N atoms" before the first section.
  for (std::size_t k = 1; k < head.size(); ++k) {
    const std::vector<std::string> words = Words(Uncommented(head[k]));
    if (words.size() == 2 && words[1] == "atoms" && Number(words[0])) return true;
    if (!words.empty() && IsSectionKeyword(words[0])) return false;
  }
  return false;
}

std::vector<BeadRecord> ReadLammpsData(Lines& lines, double metres, double max_beads) {
  std::string raw;
  lines.Next(raw);  // the title
  double atoms = -1;
  std::string style;
  bool in_atoms = false;
  while (!in_atoms && lines.Next(raw)) {
    const std::vector<std::string> words = Words(Uncommented(raw));
    if (words.empty()) continue;
    if (words.size() == 2 && words[1] == "atoms") atoms = Number(words[0]).value_or(-1);
    if (words[0] == "Atoms") {
      in_atoms = true;
      style = CommentWord(raw);
    }
  }
  if (!in_atoms) lines.Fail("no Atoms section");
  if (!(atoms >= 1 && atoms <= max_beads))
    lines.Fail("the header's \"N atoms\" must be 1 to " +
               std::to_string(static_cast<long long>(max_beads)));
  if (!style.empty() && style != "sphere" && style != "granular")
    lines.Fail("atom style " + Shown(style) +
               ": dembuf reads styles sphere and granular (id type diameter density x y z)");
  std::vector<BeadRecord> beads;
  while (static_cast<double>(beads.size()) < atoms && lines.Next(raw)) {
    const std::vector<std::string> words = Words(Uncommented(raw));
    if (words.empty()) continue;
    // id type diameter density x y z, then image flags or nothing.
    if (words.size() != 7 && words.size() != 10)
      lines.Fail("expected an atom of style sphere: id type diameter density x y z [ix iy iz]; " +
                 std::to_string(words.size()) + " values found");
    double value[7];
    for (int c = 0; c < 7; ++c) {
      const std::optional<double> v = Number(words[c]);
      if (!v) lines.Fail("not a number: " + Shown(words[c]));
      value[c] = *v;
    }
    if (words.size() == 10 && (words[7] != "0" || words[8] != "0" || words[9] != "0"))
      lines.Fail("image flags " + words[7] + " " + words[8] + " " + words[9] +
                 ": the atom lies in a periodic image; a bed in a cylinder has none");
    beads.push_back({value[4] * metres, value[5] * metres, value[6] * metres,
                     0.5 * value[2] * metres, lines.number(), value[3] / (metres * metres * metres),
                     value[1]});
  }
  if (static_cast<double>(beads.size()) < atoms)
    lines.Fail("the Atoms section ends after " + std::to_string(beads.size()) + " of " +
               std::to_string(static_cast<long long>(atoms)) + " atoms");
  return beads;
}

// ---- LAMMPS dump files -----------------------------------------------------------------------

// One frame of a LAMMPS dump after its "ITEM: TIMESTEP" line.
std::vector<BeadRecord> ReadDumpFrame(Lines& lines, double metres, double max_beads) {
  std::string raw;
  auto next_words = [&](const char* what) {
    if (!lines.Next(raw)) lines.Fail("the dump ends where " + std::string(what) + " was expected");
    return Words(raw);
  };
  auto expect_item = [&](const std::string& item) {
    next_words(("ITEM: " + item).c_str());
    if (raw.rfind("ITEM: " + item, 0) != 0)
      lines.Fail("expected \"ITEM: " + item + "\" of a LAMMPS dump");
  };
  next_words("the timestep");
  expect_item("NUMBER OF ATOMS");
  const std::vector<std::string> count = next_words("the number of atoms");
  const double atoms = count.size() == 1 ? Number(count[0]).value_or(-1) : -1;
  if (!(atoms >= 1 && atoms <= max_beads))
    lines.Fail("the number of atoms must be 1 to " +
               std::to_string(static_cast<long long>(max_beads)));
  expect_item("BOX BOUNDS");
  double lo[3], hi[3];
  for (int d = 0; d < 3; ++d) {
    const std::vector<std::string> words = next_words("the box's bounds");
    const std::optional<double> a = words.size() >= 2 ? Number(words[0]) : std::nullopt;
    const std::optional<double> b = words.size() >= 2 ? Number(words[1]) : std::nullopt;
    if (!a || !b) lines.Fail("expected the box's bounds: lo hi");
    lo[d] = *a;
    hi[d] = *b;
  }
  expect_item("ATOMS");
  const std::vector<std::string> columns = Words(raw.substr(11));
  auto column = [&](std::initializer_list<const char*> names) -> int {
    for (const char* n : names) {
      const auto it = std::find(columns.begin(), columns.end(), n);
      if (it != columns.end()) return static_cast<int>(it - columns.begin());
    }
    return -1;
  };
  const int position[3] = {column({"x", "xu"}), column({"y", "yu"}), column({"z", "zu"})};
  const int scaled[3] = {column({"xs", "xsu"}), column({"ys", "ysu"}), column({"zs", "zsu"})};
  const int radius = column({"radius"}), diameter = column({"diameter"});
  const int type = column({"type"});
  for (int d = 0; d < 3; ++d)
    if (position[d] < 0 && scaled[d] < 0)
      lines.Fail("the dump's atoms have no x y z (or xs ys zs) columns");
  if (radius < 0 && diameter < 0)
    lines.Fail(
        "the dump's atoms have no radius or diameter column (dump ... custom id type x y "
        "z radius)");
  std::vector<BeadRecord> frame;
  while (static_cast<double>(frame.size()) < atoms) {
    const std::vector<std::string> words = next_words("an atom");
    if (words.size() != columns.size())
      lines.Fail("expected " + std::to_string(columns.size()) + " values, as the ATOMS line names");
    auto value = [&](int c) {
      const std::optional<double> v = Number(words[c]);
      if (!v) lines.Fail("not a number: " + Shown(words[c]));
      return *v;
    };
    double x[3];
    for (int d = 0; d < 3; ++d)
      x[d] = position[d] >= 0 ? value(position[d]) : lo[d] + value(scaled[d]) * (hi[d] - lo[d]);
    const double r = radius >= 0 ? value(radius) : 0.5 * value(diameter);
    frame.push_back({x[0] * metres, x[1] * metres, x[2] * metres, r * metres, lines.number(), 0.0,
                     type >= 0 ? value(type) : 1.0});
  }
  return frame;
}

// The last frame of a LAMMPS dump: the settled bed where a run dumped as it went.
std::vector<BeadRecord> ReadLammpsDump(Lines& lines, double metres, double max_beads) {
  std::vector<BeadRecord> last;
  for (std::string raw; lines.Next(raw);) {
    if (Words(raw).empty()) continue;
    // A frame's units and time (dump_modify units yes, time yes) come before its timestep.
    if (raw.rfind("ITEM: UNITS", 0) == 0 ||
        (raw.rfind("ITEM: TIME", 0) == 0 && raw.rfind("ITEM: TIMESTEP", 0) != 0)) {
      if (!lines.Next(raw)) lines.Fail("the dump ends where a value of its item was expected");
      continue;
    }
    if (raw.rfind("ITEM: TIMESTEP", 0) != 0)
      lines.Fail("expected \"ITEM: TIMESTEP\", the start of a frame of a LAMMPS dump");
    last = ReadDumpFrame(lines, metres, max_beads);
  }
  return last;
}

}  // namespace

BeadRecords ReadBeadRecords(std::istream& in, const std::string& name, const std::string& unit,
                            double max_beads) {
  const double metres = MetresPerUnit(unit);
  if (metres == 0.0)
    throw SceneError("bed.import_units", Shown(unit) + " is none of m, cm, mm, um");
  Lines lines(in, name);
  const std::vector<std::string>& head = lines.head();
  const auto first = std::find_if(head.begin(), head.end(),
                                  [](const std::string& line) { return !Words(line).empty(); });
  BeadRecords records;
  if (first != head.end() &&
      (first->rfind("ITEM: TIMESTEP", 0) == 0 || first->rfind("ITEM: TIME", 0) == 0 ||
       first->rfind("ITEM: UNITS", 0) == 0)) {
    records.format = BedFileFormat::kLammpsDump;
    records.beads = ReadLammpsDump(lines, metres, max_beads);
  } else if (LooksLikeLammpsData(head)) {
    records.format = BedFileFormat::kLammpsData;
    records.beads = ReadLammpsData(lines, metres, max_beads);
  } else {
    records.beads = ReadText(lines, metres, max_beads);
  }
  return records;
}

}  // namespace dembuf
