// A sweep's aggregates (sweep_report.h): the critical thickness Hc of a thickness sweep,
// reported only where P has levelled off in the range swept; the points over the bed seeds in
// one flat shape, the rows of points.csv.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <utility>
#include <vector>

#include "dembuf/study/sweep/sweep_report.h"
#include "temp_path.h"

namespace dembuf::report {
namespace {

// P(H) = plateau + a decaying excess, at thicknesses from `low` to `high` in `n` steps.
std::vector<std::pair<double, double>> Curve(double low, double high, int n, double decay_m) {
  std::vector<std::pair<double, double>> h_to_p;
  for (int k = 0; k < n; ++k) {
    const double h = low + (high - low) * k / (n - 1);
    h_to_p.push_back({h, 1000.0 + 9000.0 * std::exp(-h / decay_m)});
  }
  return h_to_p;
}

TEST(CriticalThickness, IsFoundWhereTheCurveLevelsOff) {
  // Excess 9000 exp(-H / 5 mm): within 10% of the plateau (1000 N) from H = 5 ln(90) = 22.5 mm.
  const nlohmann::json hc = CriticalThickness(Curve(0.0, 0.08, 17, 0.005));
  ASSERT_TRUE(hc["reached"].get<bool>()) << hc.dump();
  EXPECT_NEAR(hc["Hc_m"].get<double>(), 0.025, 1e-12);  // the first grid point past 22.5 mm
  EXPECT_NEAR(hc["plateau_P_N"].get<double>(), 1000.0, 5.0);
}

TEST(CriticalThickness, IsNotReportedWhereNothingLevelsOff) {
  // 0.5-1 cm of a curve that still falls steeply there: the old rule named Hc = 0.75 cm.
  const nlohmann::json hc = CriticalThickness(Curve(0.005, 0.01, 6, 0.005));
  EXPECT_FALSE(hc["reached"].get<bool>()) << hc.dump();
  EXPECT_TRUE(hc["Hc_m"].is_null());
  const std::string note = hc["note"].get<std::string>();
  EXPECT_NE(note.find("Hc not reached in 0.5-1 cm (P still falls"), std::string::npos) << note;
  EXPECT_LT(hc["upper_half_change"].get<double>(), -0.10);
}

TEST(CriticalThickness, TheUpperHalfIsOfTheRangeSwept) {
  // 4-8 cm of the levelled curve: flat throughout; Hc is the first point swept.
  const nlohmann::json hc = CriticalThickness(Curve(0.04, 0.08, 5, 0.005));
  ASSERT_TRUE(hc["reached"].get<bool>());
  EXPECT_DOUBLE_EQ(hc["Hc_m"].get<double>(), 0.04);
  EXPECT_EQ(hc["range_m"], nlohmann::json({0.04, 0.08}));
}

// Two thicknesses over two seeds; the second seed of the thicker bed failed.
std::vector<SweepRunReport> TwoThicknessesTwoSeeds() {
  std::vector<SweepRunReport> runs;
  const double p[] = {4000.0, 4200.0, 3000.0, 0.0};
  for (int k = 0; k < 4; ++k) {
    SweepRunReport run;
    run.name = "run" + std::to_string(k);
    run.values = {k < 2 ? "0.01" : "0.02", std::to_string(1 + k % 2)};
    run.ok = k != 3;
    if (run.ok) run.summary = {{"P_N", p[k]}, {"lambda", 0.5}};
    runs.push_back(run);
  }
  return runs;
}

const std::vector<SweepAxis> kThicknessAndSeed = {{"bed.thickness_m", {"0.01", "0.02"}},
                                                  {"bed.seed", {"1", "2"}}};

TEST(SweepPoints, AreFlatRecordsOfThePointColumns) {
  const nlohmann::json points = SweepPoints(kThicknessAndSeed, TwoThicknessesTwoSeeds());
  ASSERT_EQ(points.size(), 2u);
  const std::vector<std::string> columns = SweepPointColumns(kThicknessAndSeed);
  ASSERT_GE(columns.size(), 5u);
  EXPECT_EQ(std::vector<std::string>(columns.begin(), columns.begin() + 5),
            (std::vector<std::string>{"bed.thickness_m", "runs", "P_N", "P_N_sd", "P_N_n"}));
  for (const nlohmann::json& point : points) {
    // Every column, in one flat object: numbers as numbers, null where nothing is known.
    ASSERT_EQ(point.size(), columns.size()) << point.dump();
    for (const std::string& c : columns) EXPECT_TRUE(point.contains(c)) << c;
  }
  EXPECT_EQ(points[0]["bed.thickness_m"], 0.01);
  EXPECT_EQ(points[0]["runs"], 2);
  EXPECT_DOUBLE_EQ(points[0]["P_N"].get<double>(), 4100.0);
  EXPECT_NEAR(points[0]["P_N_sd"].get<double>(), std::sqrt(2.0) * 100.0, 1e-9);
  EXPECT_EQ(points[0]["P_N_n"], 2);
  // One run that ended well: no spread (null, not 0); a metric no run has: null and n 0.
  EXPECT_EQ(points[1]["P_N"], 3000.0);
  EXPECT_TRUE(points[1]["P_N_sd"].is_null());
  EXPECT_EQ(points[1]["P_N_n"], 1);
  EXPECT_TRUE(points[1]["C0"].is_null());
  EXPECT_EQ(points[1]["C0_n"], 0);
}

TEST(SweepPoints, PointsCsvIsTheirRows) {
  const std::filesystem::path dir = test::TempPath("sweep");
  std::FILE* table = std::tmpfile();
  const nlohmann::json summary = WriteSweepReport(dir, kThicknessAndSeed, TwoThicknessesTwoSeeds(),
                                                  nlohmann::json::object(), table);
  std::fclose(table);
  std::ifstream csv(dir / "points.csv");
  std::string header, row;
  std::getline(csv, header);
  std::string wanted;
  for (const std::string& c : SweepPointColumns(kThicknessAndSeed))
    wanted += (wanted.empty() ? "" : ",") + c;
  EXPECT_EQ(header, wanted);
  std::getline(csv, row);
  // Every number exact (the JSON's double in its shortest text).
  EXPECT_EQ(row.substr(0, row.find(",,")), "0.01,2,4100,141.4213562373095,2");
  // The summary's points are the same records.
  EXPECT_EQ(summary["points"], SweepPoints(kThicknessAndSeed, TwoThicknessesTwoSeeds()));
}

TEST(SweepPoints, AreInTheOrderOfTheirValues) {
  // Speeds 2, 5 and 10 were ordered as text: 10, 2, 5 (a line plot zigzagged).
  const std::vector<SweepAxis> axes = {{"projectile.speed_m_s", {"2", "5", "10"}}};
  std::vector<SweepRunReport> runs(3);
  for (int k = 0; k < 3; ++k) runs[k].values = {axes[0].values[k]};
  const nlohmann::json points = SweepPoints(axes, runs);
  ASSERT_EQ(points.size(), 3u);
  EXPECT_EQ(points[0]["projectile.speed_m_s"], 2);
  EXPECT_EQ(points[1]["projectile.speed_m_s"], 5);
  EXPECT_EQ(points[2]["projectile.speed_m_s"], 10);
}

TEST(SweepAggregates, AThicknessSweepCarriesItsHc) {
  // One door computes the points and Hc: the daemon's answer and the folder's summary.json.
  std::vector<SweepRunReport> runs;
  std::vector<std::string> thicknesses;
  for (const auto& [h, p] : Curve(0.0, 0.08, 17, 0.005)) {
    SweepRunReport run;
    char text[32];
    std::snprintf(text, sizeof text, "%g", h);
    thicknesses.push_back(text);
    run.values = {text};
    run.ok = true;
    run.summary = {{"P_N", p}};
    runs.push_back(run);
  }
  const std::vector<SweepAxis> axes = {{"bed.thickness_m", thicknesses}};
  const nlohmann::json aggregates = SweepAggregates(axes, runs);
  EXPECT_EQ(aggregates["points"].size(), 17u);
  EXPECT_NEAR(aggregates["Hc_m"].get<double>(), 0.025, 1e-12);
  EXPECT_TRUE(aggregates["critical_thickness"]["reached"].get<bool>());
  // While runs are still to come, no Hc: the thin beds run first, and the three thinnest
  // levelled off would have given one over a range cut short.
  std::vector<SweepRunReport> under_way = runs;
  for (std::size_t k = 3; k < under_way.size(); ++k) {
    under_way[k].ok = false;
    under_way[k].summary = nullptr;
    under_way[k].state = k == 3 ? "running" : "queued";
  }
  for (std::size_t k = 0; k < 3; ++k) under_way[k].summary = {{"P_N", 1000.0}};  // flat
  const nlohmann::json partial = SweepAggregates(axes, under_way);
  EXPECT_TRUE(partial["Hc_m"].is_null()) << partial["critical_thickness"].dump();
  EXPECT_EQ(partial["critical_thickness"]["pending_runs"], 14);
  EXPECT_NE(partial["critical_thickness"]["note"].get<std::string>().find("14 of 17 runs still"),
            std::string::npos);
  // Not a thickness sweep alone: no Hc at all.
  EXPECT_FALSE(SweepAggregates(kThicknessAndSeed, TwoThicknessesTwoSeeds()).contains("Hc_m"));
}

}  // namespace
}  // namespace dembuf::report
