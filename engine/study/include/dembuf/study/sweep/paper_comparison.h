// A run or a sweep beside the paper's numbers (docs/reproduction.md): the quantities the
// paper gives for its E2 impact (Pa0 on the bare plate; Pa and lambda at 0.8 cm; lambda on the
// plateau and Hc; the dS and dt fits between the two peaks), and the Hertz peak of the same
// sphere on the bare plate without damping. Each quantity at each bed thickness is the mean of
// the runs there (the seeds); the paper's number is flagged when it lies outside their range.
#pragma once

#include <limits>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

namespace dembuf {

/// One quantity at one bed thickness, dembuf's runs against the paper.
struct ComparisonRow {
  std::string quantity;  ///< "P_N", "Pa_N", "lambda", "dS_m", "dt_peaks_s", "Hc_m", ...
  std::string label;     ///< for people: "Pa0, bare plate [kN]"
  double scale = 1.0;    ///< from the quantity's SI unit to the label's unit
  double h_m = 0.0;      ///< the bed thickness asked for (bed.thickness_m)
  double paper = 0.0;    ///< the paper's value, SI
  std::string source;    ///< where in the paper: "E2, H = 0.8 cm"
  int n = 0;             ///< runs with a value
  double mean = 0.0;
  double sd = 0.0;  ///< sample standard deviation; NaN for one run
  double min = 0.0, max = 0.0;
  double deviation = 0.0;  ///< mean / paper - 1
  /// Whether the paper's number lies within the runs' range [min, max]; empty for one run.
  std::optional<bool> paper_within_range;
};

struct Comparison {
  bool is_paper_e2 =
      false;  ///< the runs are the paper's E2 impact (or the bare plate, or a variant)
  std::vector<std::string> differs;  ///< fields by which a run's scene differs from E2
  /// Mechanisms the paper does not state that the runs add to E2 ("damping.local_alpha = 0.5",
  /// "material.density_kg_m3 = 10600"): they are compared with the paper as a variant of E2.
  std::vector<std::string> variant;
  std::vector<ComparisonRow> rows;
  /// The Hertz peak of the projectile on the bare plate, elastic (no damping), at the impact
  /// speed of the runs; 0 without runs.
  double hertz_peak_N = 0.0;
};

/// Compares the runs, given by their summary.json documents (a run of every seed and thickness
/// of a sweep, or one run). `hc_m`, when given, is a sweep's critical thickness (with its
/// uncertainty in `hc_sd_m`, NaN when unknown). Summaries missing a field are skipped for
/// that field; a document that is not a run's summary throws std::runtime_error.
Comparison CompareWithPaper(const std::vector<nlohmann::json>& summaries,
                            std::optional<double> hc_m = std::nullopt,
                            double hc_sd_m = std::numeric_limits<double>::quiet_NaN());

/// The peak force of an elastic sphere (mass, radius, E and nu) hitting a flat elastic body
/// (E and nu) at `speed`: F = K^(2/5) (5/4 m v^2)^(3/5), K = 4/3 E* sqrt(R) (Hertz).
double HertzImpactPeak(double mass_kg, double radius_m, double speed_m_s, double e1_Pa, double nu1,
                       double e2_Pa, double nu2);

/// The rows as text for a terminal, and as CSV (compare.csv).
std::string ComparisonTable(const Comparison& comparison);
std::string ComparisonCsv(const Comparison& comparison);

}  // namespace dembuf
