// Parameter tables (dembuf sweep --table): chosen points read row by row, multiplied by the
// other axes and the seeds, every value checked against its field.
#include <gtest/gtest.h>

#include "dembuf/study/scene/errors.h"
#include "dembuf/study/sweep/sweep_plan.h"

namespace dembuf {
namespace {

std::string RefusalOf(const std::string& text) {
  try {
    TableAxes(ParseSweepTable(text, "points.tsv"));
  } catch (const SceneError& e) {
    return e.what();
  }
  return "accepted";
}

TEST(SweepTable, ReadsTabsOrCommasWithCommentsAndBlankLines) {
  const SweepTable tsv = ParseSweepTable(
      "# chosen points\nprojectile.speed_m_s\tbed.thickness_m\n\n1\t0.01\r\n2 \t 0.02\n", "a");
  ASSERT_EQ(tsv.fields, (std::vector<std::string>{"projectile.speed_m_s", "bed.thickness_m"}));
  ASSERT_EQ(tsv.rows.size(), 2u);
  EXPECT_EQ(tsv.rows[1], (std::vector<std::string>{"2", "0.02"}));
  const SweepTable csv = ParseSweepTable("bed.seed,projectile.speed_m_s\n3,4\n", "b");
  EXPECT_EQ(csv.fields.front(), "bed.seed");
  EXPECT_EQ(csv.rows.front(), (std::vector<std::string>{"3", "4"}));
}

TEST(SweepTable, RowsAreOneDimensionOfTheProduct) {
  const std::vector<SweepAxis> table =
      TableAxes(ParseSweepTable("projectile.speed_m_s\tprojectile.mass_kg\n1\t0.1\n2\t0.1\n", "t"));
  std::vector<SweepAxis> axes = table;
  axes.push_back(ParseSweepAxis("bed.seed=1,2"));
  Scene base;
  base.bed.thickness_m = 0;
  const std::vector<SweepRun> runs = ExpandSweep(base, axes, 100, {}, table.size());
  ASSERT_EQ(runs.size(), 4u);  // two rows times two seeds, not 2 x 1 x 2 x ... of a product
  // (The table's values as the field table writes them: 1 of a speed is 1.0.)
  EXPECT_EQ(runs[0].values, (std::vector<std::string>{"1.0", "0.1", "1"}));
  EXPECT_EQ(runs[1].values, (std::vector<std::string>{"2.0", "0.1", "1"}));
  EXPECT_EQ(runs[3].values, (std::vector<std::string>{"2.0", "0.1", "2"}));
  EXPECT_EQ(runs[1].scene.projectile.speed_m_s, 2.0);
  EXPECT_EQ(runs[1].scene.projectile.mass_kg, 0.1);
  // The same columns as a product would be four points per seed.
  EXPECT_EQ(ExpandSweep(base, DistinctAxes(axes)).size(), 2u * 1u * 2u);
  EXPECT_EQ(DistinctAxes(table)[1].values, std::vector<std::string>{"0.1"});
}

TEST(SweepTable, RefusesWhatIsNotAPointNamingWhere) {
  EXPECT_NE(RefusalOf("projectile.sped_m_s\n1\n").find("did you mean projectile.speed_m_s?"),
            std::string::npos);
  EXPECT_NE(RefusalOf("projectile.speed_m_s\tbed.seed\n1\n")
                .find("points.tsv line 2: 1 values "
                      "for 2 columns"),
            std::string::npos);
  EXPECT_NE(RefusalOf("projectile.speed_m_s\n-1\n").find("projectile.speed_m_s"),
            std::string::npos);
  EXPECT_NE(RefusalOf("projectile.speed_m_s\n1\n1.0\n")
                .find("rows 1 and 2 (after the header) are the same"),
            std::string::npos);
  EXPECT_NE(RefusalOf("bed.seed\tbed.seed\n1\t2\n").find("the column is given twice"),
            std::string::npos);
  EXPECT_NE(RefusalOf("# nothing\n").find("needs a header"), std::string::npos);
  EXPECT_NE(RefusalOf("bed.seed\n").find("needs a header"), std::string::npos);
}

// From a review: a table of no rows made a sweep of no jobs (stored outside every quota), a
// count of seeds beside a bed.seed column was dropped without a word, and a value of
// thousands of digits was copied into every run.
TEST(SweepTable, RefusesAnEmptySweepSeedsTwiceAndLongValues) {
  Scene base;
  base.bed.thickness_m = 0;
  EXPECT_THROW(ExpandSweep(base, {SweepAxis{"projectile.speed_m_s", {}}}, 100, {}, 1), SceneError);
  const std::vector<SweepAxis> seeded = TableAxes(ParseSweepTable("bed.seed\n1\n2\n", "t"));
  EXPECT_THROW(WithSeedAxis(seeded, 3), SceneError);
  EXPECT_EQ(WithSeedAxis(seeded, 1).size(), 1u);
  EXPECT_NE(RefusalOf("bed.thickness_m\n0." + std::string(600, '0') + "1\n").find("at most 512"),
            std::string::npos);
  EXPECT_NE(RefusalOf("projectile.speed_m_s projectile.mass_kg\n1 2\n")
                .find("separate the columns by tabs or commas"),
            std::string::npos);
  // 1e-2 and 0.01 are one point.
  EXPECT_NE(RefusalOf("bed.thickness_m\n0.01\n1e-2\n").find("are the same"), std::string::npos);
}

}  // namespace
}  // namespace dembuf
