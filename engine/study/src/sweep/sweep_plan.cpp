#include "dembuf/study/sweep/sweep_plan.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>

#include "dembuf/study/bed/bed.h"
#include "dembuf/study/scene/errors.h"
#include "dembuf/study/scene/scene_fields.h"
#include "dembuf/study/text/number_text.h"
#include "dembuf/study/text/text_limits.h"

namespace dembuf {

namespace {

// The value of a range point as text: the fewest digits that stay within a millionth of the
// step of it, so that 3 * 0.005 reads 0.015 (not 0.015000000000000001) and points 1e-14
// apart keep the digits that tell them apart (12 digits once made them one point).
std::string RangeValueText(double v, double step) {
  char buf[40];
  for (int digits = 1; digits <= 17; ++digits) {
    std::snprintf(buf, sizeof buf, "%.*g", digits, v);
    if (std::abs(std::strtod(buf, nullptr) - v) <= 1e-6 * step) break;
  }
  return buf;
}

double ParseNumber(const std::string& field, const std::string& text) {
  try {
    std::size_t used = 0;
    const double v = std::stod(text, &used);
    if (used == text.size() && std::isfinite(v)) return v;
  } catch (const std::exception&) {
  }
  throw SceneError(field, "\"" + text + "\" is not a number in the sweep range");
}

std::vector<std::string> ExpandRange(const std::string& field, const std::string& range) {
  if (std::count(range.begin(), range.end(), ':') != 2)
    throw SceneError(field, "range \"" + range + "\" must be START:STOP:STEP");
  const auto c1 = range.find(':'), c2 = range.rfind(':');
  const double start = ParseNumber(field, range.substr(0, c1));
  const double stop = ParseNumber(field, range.substr(c1 + 1, c2 - c1 - 1));
  const double step = ParseNumber(field, range.substr(c2 + 1));
  if (!(step > 0.0) || stop < start)
    throw SceneError(field, "range " + range + " needs STEP > 0 and STOP >= START");
  const double count = std::floor((stop - start) / step + 1e-9) + 1;
  if (count > 10000) throw SceneError(field, "range " + range + " has over 10000 values");
  std::vector<std::string> values;
  for (long k = 0; k < static_cast<long>(count); ++k)
    values.push_back(RangeValueText(start + k * step, step));
  return values;
}

}  // namespace

void CheckSweepValueLength(const std::string& field, const std::string& value) {
  // Each value is copied into every run's name and record: a long one costs runs times over.
  if (value.size() > kMaxSweepValueBytes)
    throw SceneError(field, "a swept value of " + std::to_string(value.size()) +
                                " bytes; at most " + std::to_string(kMaxSweepValueBytes));
}

SweepAxis MakeSweepAxis(const std::string& field, const std::vector<std::string>& values,
                        const std::string& range) {
  RequireSceneField(field);
  if (values.empty() == range.empty())
    throw SceneError(field,
                     "a sweep axis needs either a list of values or a START:STOP:STEP "
                     "range");
  SweepAxis axis{field, range.empty() ? values : ExpandRange(field, range)};
  // Every value must be valid for the field before anything runs, and say something the
  // others do not (1 and 1.0 would run the same point twice, labelled as two).
  Scene probe;
  std::map<std::string, std::string> seen;  // the field's value as the scene holds it
  for (const std::string& v : axis.values) {
    if (v.empty()) throw SceneError(field, "empty value in the sweep axis");
    CheckSweepValueLength(field, v);
    SetSceneField(probe, field, v);
    const auto [at, fresh] = seen.emplace(FormatSceneField(probe, RequireSceneField(field)), v);
    if (!fresh)
      throw SceneError(field, "the value " + v + " is given twice" +
                                  (at->second == v ? "" : " (as " + at->second + " too)") +
                                  " in the sweep axis");
  }
  return axis;
}

SweepSpec SplitSweepSpec(const std::string& spec) {
  const auto eq = spec.find('=');
  SweepSpec parts;
  parts.field = spec.substr(0, eq);
  const std::string rest = eq == std::string::npos ? "" : spec.substr(eq + 1);
  if (rest.find(':') != std::string::npos) {
    parts.range = rest;
    return parts;
  }
  std::size_t begin = 0;
  while (true) {
    const auto comma = rest.find(',', begin);
    parts.values.push_back(
        rest.substr(begin, comma == std::string::npos ? std::string::npos : comma - begin));
    if (comma == std::string::npos) break;
    begin = comma + 1;
  }
  return parts;
}

SweepAxis ParseSweepAxis(const std::string& spec) {
  const auto eq = spec.find('=');
  if (eq == std::string::npos || eq == 0)
    throw SceneError("", "--vary \"" + spec +
                             "\" must be dotted.field=START:STOP:STEP or dotted.field=v1,v2,...");
  const SweepSpec parts = SplitSweepSpec(spec);
  return MakeSweepAxis(parts.field, parts.values, parts.range);
}

std::string SweepSeedsProblem(int seeds) {
  if (seeds >= 1 && seeds <= kMaxSweepSeeds) return "";
  return std::to_string(seeds) + " is out of range: 1 to " + std::to_string(kMaxSweepSeeds);
}

std::vector<SweepAxis> WithSeedAxis(std::vector<SweepAxis> axes, int seeds,
                                    std::int64_t first_seed) {
  if (std::any_of(axes.begin(), axes.end(),
                  [](const SweepAxis& a) { return a.field == "bed.seed"; })) {
    if (seeds > 1)
      throw SceneError("seeds", std::to_string(seeds) +
                                    ": bed.seed is swept already (an axis or a table's column); "
                                    "give the seeds there, not as a count");
    return axes;
  }
  if (const std::string problem = SweepSeedsProblem(seeds); !problem.empty())
    throw SceneError("seeds", problem);
  SweepAxis seed{"bed.seed", {}};
  for (int s = 0; s < seeds; ++s) seed.values.push_back(std::to_string(first_seed + s));
  axes.push_back(std::move(seed));
  return axes;
}

std::vector<SweepRun> ExpandSweep(const Scene& base, const std::vector<SweepAxis>& axes,
                                  std::size_t max_runs, const RunAdmission& admit,
                                  std::size_t table_columns) {
  // One axis per field: a field varied twice would label one axis's results with the other's
  // values.
  for (std::size_t a = 0; a < axes.size(); ++a)
    for (std::size_t b = 0; b < a; ++b)
      if (axes[a].field == axes[b].field) throw SceneError(axes[a].field, "varied twice");
  // The dimensions multiplied: the table's rows (its columns read together), then each axis.
  table_columns = std::min(table_columns, axes.size());
  std::vector<std::size_t> sizes;
  if (table_columns > 0) sizes.push_back(axes.front().values.size());
  for (std::size_t a = table_columns; a < axes.size(); ++a) sizes.push_back(axes[a].values.size());
  for (std::size_t a = 1; a < table_columns; ++a)
    if (axes[a].values.size() != sizes.front())
      throw SceneError(axes[a].field, "a table column of " + std::to_string(axes[a].values.size()) +
                                          " values beside " + std::to_string(sizes.front()));
  double count = 1;
  for (std::size_t size : sizes) count *= static_cast<double>(size);
  if (count == 0) throw SceneError("axes", "the sweep has no runs: an axis or table is empty");
  if (count > static_cast<double>(max_runs))
    throw SceneError("axes", "the sweep has " + NumberText(count, 12) + " runs; at most " +
                                 std::to_string(max_runs) + " are allowed");
  // The value index of each axis for a pick of the dimensions.
  auto value_of = [&](const std::vector<std::size_t>& pick, std::size_t a) {
    if (a < table_columns) return pick.front();
    return pick[a - table_columns + (table_columns > 0 ? 1 : 0)];
  };
  std::vector<SweepRun> runs;
  std::vector<std::size_t> pick(sizes.size(), 0);
  while (count > 0) {
    SweepRun run;
    run.index = runs.size();
    run.scene = base;
    char index[16];
    std::snprintf(index, sizeof index, "%03zu", run.index);
    run.name = index;
    for (std::size_t a = 0; a < axes.size(); ++a) {
      run.values.push_back(axes[a].values[value_of(pick, a)]);
      SetSceneField(run.scene, axes[a].field, run.values.back());
      // Appended piece by piece: GCC 12 warns falsely (-Wrestrict) on "_" + std::string.
      run.name.append("_").append(axes[a].field.substr(axes[a].field.rfind('.') + 1));
      run.name.append("=").append(run.values.back());
    }
    if (admit) admit(run.scene);
    ValidateScene(run.scene);
    run.beds = BedNeedsOf(run.scene);
    runs.push_back(std::move(run));
    std::size_t d = 0;
    while (d < sizes.size() && ++pick[d] == sizes[d]) pick[d++] = 0;
    if (d == sizes.size()) break;
  }
  return runs;
}

SweepTable ParseSweepTable(std::string_view text, const std::string& name) {
  SweepTable table;
  char separator = '\t';
  std::size_t line_number = 0;
  auto where = [&] { return name + " line " + std::to_string(line_number); };
  while (!text.empty()) {
    const std::size_t end = std::min(text.find('\n'), text.size());
    std::string_view line = text.substr(0, end);
    text.remove_prefix(std::min(end + 1, text.size()));
    ++line_number;
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    if (line.find_first_not_of(" \t") == std::string_view::npos || line.front() == '#') continue;
    if (table.fields.empty() && line.find('\t') == std::string_view::npos) separator = ',';
    std::vector<std::string> cells;
    for (std::size_t begin = 0;;) {
      const std::size_t cut = std::min(line.find(separator, begin), line.size());
      std::string_view cell = line.substr(begin, cut - begin);
      while (!cell.empty() && cell.front() == ' ') cell.remove_prefix(1);
      while (!cell.empty() && cell.back() == ' ') cell.remove_suffix(1);
      cells.emplace_back(cell);
      if (cut == line.size()) break;
      begin = cut + 1;
    }
    if (table.fields.empty()) {
      for (const std::string& field : cells) {
        if (field.empty()) throw SceneError("--table", where() + ": a column without a field name");
        if (field.find_first_of(" ;") != std::string::npos)
          throw SceneError("--table", where() + ": \"" + field +
                                          "\" is not a field name: separate the columns by tabs "
                                          "or commas");
        RequireSceneField(field);
        if (std::count(cells.begin(), cells.end(), field) > 1)
          throw SceneError(field, where() + ": the column is given twice");
      }
      table.fields = std::move(cells);
      continue;
    }
    if (cells.size() != table.fields.size())
      throw SceneError("--table", where() + ": " + std::to_string(cells.size()) + " values for " +
                                      std::to_string(table.fields.size()) + " columns");
    if (table.rows.size() >= kMaxTableRows)
      throw SceneError("--table", name + ": more than " + std::to_string(kMaxTableRows) + " rows");
    table.rows.push_back(std::move(cells));
  }
  if (table.fields.empty() || table.rows.empty())
    throw SceneError("--table", name + ": needs a header of field names and a row per point");
  return table;
}

std::string CanonicalSweepValue(const std::string& field, const std::string& text) {
  Scene probe;
  SetSceneField(probe, field, text);
  return FormatSceneField(probe, RequireSceneField(field));
}

std::vector<SweepAxis> DistinctAxes(std::vector<SweepAxis> axes) {
  for (SweepAxis& axis : axes) {
    std::vector<std::string> distinct;
    for (std::string& v : axis.values)
      if (std::find(distinct.begin(), distinct.end(), v) == distinct.end())
        distinct.push_back(std::move(v));
    axis.values = std::move(distinct);
  }
  return axes;
}

SweepTable ReadSweepTableFile(const std::string& path) {
  constexpr std::size_t kMaxTableBytes = 16 << 20;  // 100,000 rows of a few fields
  std::string text;
  try {
    text = ReadBoundedFile(path, kMaxTableBytes, "table");
  } catch (const std::exception& e) {
    throw SceneError("--table", e.what());
  }
  return ParseSweepTable(text, path);
}

std::vector<SweepAxis> TableAxes(const SweepTable& table) {
  std::vector<SweepAxis> columns;
  for (const std::string& field : table.fields) {
    RequireSceneField(field);
    columns.push_back({field, {}});
  }
  // Every value valid for its field, and no point twice (as the scene holds its values: 1 and
  // 1.0 are one point).
  std::map<std::string, std::size_t> seen;
  for (std::size_t r = 0; r < table.rows.size(); ++r) {
    const std::vector<std::string>& row = table.rows[r];
    if (row.size() != columns.size())
      throw SceneError("table", "row " + std::to_string(r + 1) + " has " +
                                    std::to_string(row.size()) + " values for " +
                                    std::to_string(columns.size()) + " columns");
    Scene probe;
    std::string point;
    for (std::size_t c = 0; c < columns.size(); ++c) {
      if (row[c].empty())
        throw SceneError(columns[c].field, "row " + std::to_string(r + 1) + ": no value");
      CheckSweepValueLength(columns[c].field, row[c]);
      SetSceneField(probe, columns[c].field, row[c]);
      // As the field table writes it: 1e-2 and 0.01 are one value, in the record and the runs.
      columns[c].values.push_back(FormatSceneField(probe, RequireSceneField(columns[c].field)));
      point += columns[c].values.back() + '\n';
    }
    if (const auto [at, fresh] = seen.emplace(point, r + 1); !fresh)
      throw SceneError("table", "the points of rows " + std::to_string(at->second) + " and " +
                                    std::to_string(r + 1) + " (after the header) are the same");
  }
  return columns;
}

}  // namespace dembuf
