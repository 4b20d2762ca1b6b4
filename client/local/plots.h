// PNG plots of a run or a sweep folder, drawn by gnuplot (Debian package gnuplot-nox).
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace dembuf::cli {

/// Whether gnuplot can be run.
bool GnuplotAvailable();

/// Plots what the folder holds: a run (plate_force.csv, snapshots/) or a sweep (points.csv,
/// runs/). Returns the PNG files written; throws std::runtime_error if gnuplot fails.
std::vector<std::filesystem::path> PlotFolder(const std::filesystem::path& dir);

/// compare.png in `dir`, from its compare_points.csv: dembuf's P(H) and lambda(H) (mean and
/// sd over seeds) with the paper's E2 numbers and the Hertz bare-plate peak, for beds up to
/// h_max_m; `variant` names what the runs add to E2 (Comparison::variant), in the
/// title. Returns the file.
std::filesystem::path PlotComparison(const std::filesystem::path& dir, double hertz_peak_N,
                                     double h_max_m, const std::vector<std::string>& variant = {});

/// Plots a finished run or sweep folder when gnuplot is there, saying what it did; a missing
/// gnuplot is not an error.
void PlotIfPossible(const std::filesystem::path& dir);

}  // namespace dembuf::cli
