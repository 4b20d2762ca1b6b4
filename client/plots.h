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

/// Plots a finished run or sweep folder when gnuplot is there, saying what it did; a missing
/// gnuplot is not an error.
void PlotIfPossible(const std::filesystem::path& dir);

}  // namespace dembuf::cli
