#include "dembuf/study/sweep/sweep_plan.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>

#include "dembuf/study/bed/bed.h"
#include "dembuf/study/scene/errors.h"
#include "dembuf/study/scene/scene_fields.h"
#include "dembuf/study/text/number_text.h"

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
                  [](const SweepAxis& a) { return a.field == "bed.seed"; }))
    return axes;
  if (const std::string problem = SweepSeedsProblem(seeds); !problem.empty())
    throw SceneError("seeds", problem);
  SweepAxis seed{"bed.seed", {}};
  for (int s = 0; s < seeds; ++s) seed.values.push_back(std::to_string(first_seed + s));
  axes.push_back(std::move(seed));
  return axes;
}

std::vector<SweepRun> ExpandSweep(const Scene& base, const std::vector<SweepAxis>& axes,
                                  std::size_t max_runs, const RunAdmission& admit) {
  // One axis per field: a field varied twice would label one axis's results with the other's
  // values.
  for (std::size_t a = 0; a < axes.size(); ++a)
    for (std::size_t b = 0; b < a; ++b)
      if (axes[a].field == axes[b].field) throw SceneError(axes[a].field, "varied twice");
  double count = 1;
  for (const SweepAxis& axis : axes) count *= static_cast<double>(axis.values.size());
  if (count > static_cast<double>(max_runs))
    throw SceneError("axes", "the sweep has " + NumberText(count, 12) + " runs; at most " +
                                 std::to_string(max_runs) + " are allowed");
  std::vector<SweepRun> runs;
  std::vector<std::size_t> pick(axes.size(), 0);
  while (count > 0) {
    SweepRun run;
    run.index = runs.size();
    run.scene = base;
    char index[16];
    std::snprintf(index, sizeof index, "%03zu", run.index);
    run.name = index;
    for (std::size_t a = 0; a < axes.size(); ++a) {
      run.values.push_back(axes[a].values[pick[a]]);
      SetSceneField(run.scene, axes[a].field, run.values.back());
      // Appended piece by piece: GCC 12 warns falsely (-Wrestrict) on "_" + std::string.
      run.name.append("_").append(axes[a].field.substr(axes[a].field.rfind('.') + 1));
      run.name.append("=").append(run.values.back());
    }
    if (admit) admit(run.scene);
    ValidateScene(run.scene);
    run.beds = BedNeedsOf(run.scene);
    runs.push_back(std::move(run));
    std::size_t a = 0;
    while (a < axes.size() && ++pick[a] == axes[a].values.size()) pick[a++] = 0;
    if (a == axes.size()) break;
  }
  return runs;
}

}  // namespace dembuf
