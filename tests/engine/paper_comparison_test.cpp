// dembuf compare's arithmetic on fixtures: summaries made by hand for the paper's E2 scene,
// with the deviations and the range flags worked out here.
#include <gtest/gtest.h>

#include <cmath>

#include "dembuf/study/files/run_output.h"
#include "dembuf/study/scene/presets.h"
#include "dembuf/study/sweep/paper_comparison.h"

namespace dembuf {
namespace {

// A run's summary.json for E2 at thickness h with the given P (N) and lambda.
nlohmann::json E2Run(double h, double p, double lambda, Scene scene = PresetScene("e2")) {
  scene.bed.thickness_m = h;
  return {{"scene", report::SceneToJson(scene)},
          {"P_N", p},
          {"lambda", lambda},
          {"impact_speed_m_s", 5.513}};
}

const ComparisonRow* Find(const Comparison& c, const std::string& quantity, double h) {
  for (const auto& row : c.rows)
    if (row.quantity == quantity && std::abs(row.h_m - h) < 1e-9) return &row;
  return nullptr;
}

TEST(PaperComparison, SeedsAroundThePapersNumberAreWithinRange) {
  const auto c = CompareWithPaper(
      {E2Run(0.008, 6000, 0.45), E2Run(0.008, 6500, 0.52), E2Run(0.008, 7000, 0.55)});
  ASSERT_TRUE(c.is_paper_e2);
  const auto* p = Find(c, "P_N", 0.008);
  ASSERT_NE(p, nullptr);
  EXPECT_EQ(p->n, 3);
  EXPECT_DOUBLE_EQ(p->mean, 6500);
  EXPECT_DOUBLE_EQ(p->sd, 500);
  EXPECT_NEAR(p->deviation, 6500.0 / 6730.0 - 1.0, 1e-12);
  ASSERT_TRUE(p->paper_within_range);
  EXPECT_TRUE(*p->paper_within_range);
  const auto* lambda = Find(c, "lambda", 0.008);
  ASSERT_NE(lambda, nullptr);
  EXPECT_NEAR(lambda->mean, 1.52 / 3, 1e-12);
  EXPECT_NEAR(lambda->deviation, (1.52 / 3) / 0.50 - 1.0, 1e-12);
  EXPECT_TRUE(*lambda->paper_within_range);
}

TEST(PaperComparison, ARunOutsideTheSpreadIsFlagged) {
  const auto c = CompareWithPaper(
      {E2Run(0.008, 4000, 0.70), E2Run(0.008, 4500, 0.66), E2Run(0.008, 5000, 0.63)});
  const auto* p = Find(c, "P_N", 0.008);
  ASSERT_NE(p, nullptr);
  ASSERT_TRUE(p->paper_within_range);
  EXPECT_FALSE(*p->paper_within_range);  // 6.73 kN is above all three
  EXPECT_NE(ComparisonTable(c).find("NO: outside"), std::string::npos);
  // One run has no range: nothing is claimed either way.
  const auto one = CompareWithPaper({E2Run(0.008, 4000, 0.70)});
  EXPECT_FALSE(Find(one, "P_N", 0.008)->paper_within_range);
  EXPECT_TRUE(std::isnan(Find(one, "P_N", 0.008)->sd));
}

TEST(PaperComparison, TheFitsBetweenThePeaksAndTheBarePlate) {
  nlohmann::json thick = E2Run(0.04, 2000, 0.85);
  thick["dS_m"] = 0.03;
  thick["dt_peaks_s"] = 0.02;
  const auto c = CompareWithPaper({E2Run(0.0, 13380, 0.0), thick});
  EXPECT_NEAR(Find(c, "P_N", 0.0)->deviation, 13380.0 / 13460.0 - 1.0, 1e-12);
  // dS = 0.91 H - 0.32 = 3.32 cm; dt above 3.5 cm = 10.36 H - 21.61 = 19.83 ms (H = 4 cm).
  EXPECT_NEAR(Find(c, "dS_m", 0.04)->paper, 0.0332, 1e-12);
  EXPECT_NEAR(Find(c, "dt_peaks_s", 0.04)->paper, 0.01983, 1e-12);
  EXPECT_NEAR(Find(c, "lambda", 0.04)->paper, 0.84, 1e-12);  // the plateau
}

TEST(PaperComparison, HcWithItsUncertainty) {
  const auto c = CompareWithPaper({E2Run(0.03, 2000, 0.85)}, 0.025, 0.002);
  const auto* hc = Find(c, "Hc_m", 0.0);
  ASSERT_NE(hc, nullptr);
  EXPECT_NEAR(hc->deviation, 0.25, 1e-12);
  EXPECT_FALSE(*hc->paper_within_range);  // 2 cm is outside 2.5 +- 2 x 0.2 cm
}

TEST(PaperComparison, AnotherSceneGetsNoPaperNumbers) {
  Scene other = PresetScene("e2");
  other.material.friction_bead_bead = 0.2;
  const auto c = CompareWithPaper({E2Run(0.008, 6500, 0.5, other)});
  EXPECT_FALSE(c.is_paper_e2);
  EXPECT_TRUE(c.rows.empty());
  ASSERT_EQ(c.differs.size(), 1u);
  EXPECT_EQ(c.differs[0], "material.friction_bead_bead");
  // The accuracy, the seed and the cut do not change what is compared.
  Scene knobs = PresetScene("e2");
  knobs.time.alpha = 0.05;
  knobs.bed.seed = 7;
  knobs.bed.cut = "tops";
  EXPECT_TRUE(CompareWithPaper({E2Run(0.008, 6500, 0.5, knobs)}).is_paper_e2);
}

// A variant of E2 (a mechanism the paper's model does not state) is compared with the paper,
// and the table says which: the strike peak Pb against the plateau it carries in the paper.
TEST(PaperComparison, AVariantOfE2IsComparedAndNamed) {
  Scene damped = PresetScene("e2");
  damped.bead_damping.local_alpha = 0.5;
  nlohmann::json run = E2Run(0.04, 2000, 0.85, damped);
  run["Pb_N"] = 1800.0;
  run["dt_peaks_s"] = 0.018;
  const auto c = CompareWithPaper({run});
  ASSERT_TRUE(c.is_paper_e2);
  EXPECT_TRUE(c.differs.empty());
  ASSERT_EQ(c.variant.size(), 1u);
  EXPECT_EQ(c.variant[0], "damping.local_alpha = 0.5");
  const auto* pb = Find(c, "Pb_N", 0.04);
  ASSERT_NE(pb, nullptr);
  EXPECT_NEAR(pb->paper, 13460 * 0.16, 1e-9);
  EXPECT_NEAR(pb->deviation, 1800 / (13460 * 0.16) - 1, 1e-12);
  EXPECT_NE(ComparisonTable(c).find("does not state: damping.local_alpha = 0.5"),
            std::string::npos);
  EXPECT_NE(ComparisonCsv(c).find("variant,,,\"damping.local_alpha = 0.5\""), std::string::npos);
  // Beads four times as dense: the control of the study, a variant too.
  Scene heavy = PresetScene("e2");
  heavy.material.density_kg_m3 *= 4;
  EXPECT_TRUE(CompareWithPaper({E2Run(0.04, 2000, 0.85, heavy)}).is_paper_e2);
}

// A run made before a scene field existed lacks it in its summary: it had the field's default.
TEST(PaperComparison, ARunWithoutALaterFieldHadItsDefault) {
  nlohmann::json older = E2Run(0.008, 6500, 0.5);
  older["scene"].erase("damping");
  EXPECT_TRUE(CompareWithPaper({older}).is_paper_e2);
  // A field whose default is not E2's still differs when it is missing.
  nlohmann::json no_projectile = E2Run(0.008, 6500, 0.5);
  no_projectile["scene"]["projectile"].erase("height_m");
  const auto c = CompareWithPaper({no_projectile});
  EXPECT_FALSE(c.is_paper_e2);
  ASSERT_EQ(c.differs.size(), 1u);
  EXPECT_EQ(c.differs[0], "projectile.height_m");
}

// E2 runs at a thickness the paper gives no number for: the table says which thicknesses do.
TEST(PaperComparison, AnEmptyTableSaysWhichThicknessesTheFiguresAreAt) {
  const auto c = CompareWithPaper({E2Run(0.003, 9000, 0.3)});
  EXPECT_TRUE(c.is_paper_e2);
  EXPECT_TRUE(c.rows.empty());
  EXPECT_NE(ComparisonTable(c).find("no paper number at these runs' thicknesses: the "
                                    "paper gives P at 0 and 0.8 cm"),
            std::string::npos);
  EXPECT_EQ(ComparisonTable(CompareWithPaper({E2Run(0.008, 6500, 0.5)})).find("no paper number"),
            std::string::npos);
}

// Hertz: the peak force F = K x^(3/2) at the deepest overlap x, where the kinetic energy is all
// elastic, 1/2 m v^2 = 2/5 K x^(5/2). The paper's projectile on the bare plate: MODEL.md says
// about 13.5 kN.
TEST(PaperComparison, HertzPeakFromTheEnergyBalance) {
  const double m = 0.3, r = 0.025, v = 5.513, e = 5e9, nu = 0.22;
  const double e_star = e / (2 * (1 - nu * nu));
  const double k = 4.0 / 3.0 * e_star * std::sqrt(r);
  const double x = std::pow(0.5 * m * v * v / (0.4 * k), 0.4);
  const double f = HertzImpactPeak(m, r, v, e, nu, e, nu);
  EXPECT_NEAR(f, k * std::pow(x, 1.5), 1e-9 * f);
  EXPECT_NEAR(f, 13.5e3, 0.01 * 13.5e3);
}

// A summary whose scene lacks its parts (a hostile server's, a hand-made one): refused with a
// sentence, not read past the end of the JSON (undefined behaviour).
TEST(PaperComparison, ASceneWithoutItsPartsIsRefused) {
  nlohmann::json bare = E2Run(0.02, 6000, 0.5);
  bare["scene"] = {{"bed", {{"thickness_m", 0.02}}}};
  EXPECT_THROW(CompareWithPaper({bare}), std::runtime_error);
}

// The reference Hertz peak is the scene's: it changed with the set of runs given (their
// measured speeds at first contact differ with the bed).
TEST(PaperComparison, TheHertzPeakIsTheScenesWhicheverRunsAreGiven) {
  nlohmann::json thin = E2Run(0.008, 6000, 0.45), thick = E2Run(0.04, 3000, 0.8);
  thin["impact_speed_m_s"] = 5.40;
  thick["impact_speed_m_s"] = 5.55;
  const double one = CompareWithPaper({thin}).hertz_peak_N;
  EXPECT_DOUBLE_EQ(CompareWithPaper({thin, thick}).hertz_peak_N, one);
  // E2: 0.3 kg, 5 cm across, 5 m/s with its centre 30 cm above the surface (27.5 cm of fall):
  // 5.51 m/s at first contact.
  const Scene e2 = PresetScene("e2");
  const double fall = e2.projectile.height_m - 0.5 * e2.projectile.diameter_m;
  const double v =
      std::sqrt(e2.projectile.speed_m_s * e2.projectile.speed_m_s + 2.0 * e2.gravity_m_s2 * fall);
  const double e = e2.material.youngs_modulus_Pa, nu = e2.material.poisson_ratio;
  EXPECT_DOUBLE_EQ(
      one, HertzImpactPeak(e2.projectile.mass_kg, 0.5 * e2.projectile.diameter_m, v, e, nu, e, nu));
}

}  // namespace
}  // namespace dembuf
