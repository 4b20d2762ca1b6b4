// A sweep's plan: the product of varied scene fields (and bed seeds) as a list of validated
// scenes, ordered so that runs on the same settled source bed are spread out. Shared by the
// local `dembuf sweep` and the daemon, which expands a sweep request into jobs.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include "dembuf/study/bed/bed.h"
#include "dembuf/study/scene/scene.h"

namespace dembuf {

/// One varied field and its values (as text, applied with SetSceneField).
struct SweepAxis {
  std::string field;
  std::vector<std::string> values;
};

/// The parts of "dotted.field=START:STOP:STEP" or "dotted.field=v1,v2,...", not checked
/// (a client passes them on to the daemon, which checks them).
struct SweepSpec {
  std::string field;
  std::vector<std::string> values;  ///< the listed values, or
  std::string range;                ///< "START:STOP:STEP"
};
SweepSpec SplitSweepSpec(const std::string& spec);

/// Parses and checks "dotted.field=START:STOP:STEP" (inclusive) or "dotted.field=v1,v2,...".
/// Throws SceneError naming the field.
SweepAxis ParseSweepAxis(const std::string& spec);

/// An axis from a field and either explicit values or a "START:STOP:STEP" range; every value
/// is checked against the field, and no two may be the same value. Range values keep the
/// digits that tell them apart. Throws SceneError naming the field.
SweepAxis MakeSweepAxis(const std::string& field, const std::vector<std::string>& values,
                        const std::string& range);

/// The longest swept value, in bytes (a path of bed.import fits): each is copied into every run.
inline constexpr std::size_t kMaxSweepValueBytes = 512;
/// Throws SceneError naming the field for a value longer than kMaxSweepValueBytes.
void CheckSweepValueLength(const std::string& field, const std::string& value);

/// The most bed seeds a sweep runs of each point: the rule of `dembuf sweep --seeds` and of the
/// daemon's SubmitSweep alike.
inline constexpr int kMaxSweepSeeds = 1000;
/// "" for a number of seeds a sweep may run, else why not ("2000 is out of range: 1 to 1000").
std::string SweepSeedsProblem(int seeds);

/// Adds the axis bed.seed = first_seed .. first_seed + seeds - 1 unless bed.seed is already
/// varied (then seeds must be 1). Throws SceneError (seeds) where SweepSeedsProblem says why
/// not, or for seeds > 1 beside a swept bed.seed.
std::vector<SweepAxis> WithSeedAxis(std::vector<SweepAxis> axes, int seeds,
                                    std::int64_t first_seed = 1);

/// One run of a sweep.
struct SweepRun {
  std::size_t index = 0;
  std::vector<std::string> values;  ///< one per axis
  Scene scene;
  BedNeeds beds;     ///< the source bed it is cut from and its own bed
  std::string name;  ///< e.g. "003_thickness_m=0.01_seed=2"
};

/// What a caller checks of each run's scene as soon as the axes are set on it, before
/// anything else reads it (the daemon's admission, which must see a path before it is looked
/// up). Throws SceneError to refuse the sweep.
using RunAdmission = std::function<void(const Scene&)>;

/// The product of the axes on top of `base`, every scene admitted (when `admit` is given) and
/// validated. The first `table_columns` axes are a table's columns (TableAxes): read together,
/// row by row, as one dimension of the product. Throws SceneError naming the field (a field
/// varied twice among them), or when the product has more than max_runs runs.
std::vector<SweepRun> ExpandSweep(const Scene& base, const std::vector<SweepAxis>& axes,
                                  std::size_t max_runs = 100000, const RunAdmission& admit = {},
                                  std::size_t table_columns = 0);

/// A table of chosen points (dembuf sweep --table, yade-batch's parameter table): a scene
/// field per column, a row of values per point; bed.seed may be a column.
struct SweepTable {
  std::vector<std::string> fields;
  std::vector<std::vector<std::string>> rows;
};
/// The most rows a table may have (as many as a sweep's runs).
inline constexpr std::size_t kMaxTableRows = 100000;

/// Reads a table: a header line of field names, then a line of values per point, separated by
/// tabs (TSV) or, where the header has no tab, commas; blank lines and lines starting with
/// "#" are skipped. `name` names the file in errors. Throws SceneError naming the line.
SweepTable ParseSweepTable(std::string_view text, const std::string& name);

/// A swept value as the field table writes it (1 of projectile.speed_m_s reads "1.0"): as a
/// local sweep's reports hold a run's values, and a fetched sweep's too. Throws SceneError.
std::string CanonicalSweepValue(const std::string& field, const std::string& text);

/// The axes with each value once, in the order first given: a table's columns (whose values
/// repeat row by row) as a sweep's record and report show them.
std::vector<SweepAxis> DistinctAxes(std::vector<SweepAxis> axes);

/// The table in a file (of at most 16 MiB). Throws SceneError naming --table.
SweepTable ReadSweepTableFile(const std::string& path);

/// The table's columns as axes for ExpandSweep (each column's values in row order), every
/// value checked against its field and no point given twice. Throws SceneError naming the
/// field or the rows.
std::vector<SweepAxis> TableAxes(const SweepTable& table);

}  // namespace dembuf
