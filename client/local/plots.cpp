#include "local/plots.h"

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <sstream>
#include <stdexcept>

#include "dembuf/study/files/own_files.h"
#include "dembuf/study/files/run_output.h"
#include "dembuf/study/scene/scene_fields.h"
#include "dembuf/study/spawn/program.h"
#include "dembuf/study/sweep/sweep_report.h"

namespace dembuf::cli {

namespace fs = std::filesystem;

namespace {

constexpr const char* kTerminal =
    "set terminal pngcairo size 1000,640 font 'DejaVu Sans,12'\n"
    "set datafile separator ','\nset key top right noenhanced\nset grid\nset termoption "
    "noenhanced\n";

// Any text as a gnuplot string literal: every string that reaches a script (folder names,
// CSV headers, labels from summary.json) goes through here, so that it is data, never code.
// In single quotes gnuplot substitutes nothing (no backquotes, no macros) and a quote is
// doubled; a control character (a newline would end the command) becomes '?'.
std::string Literal(std::string_view text) {
  std::string out = "'";
  for (const char c : text) {
    if (c == '\'')
      out += "''";
    else if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f)
      out += '?';
    else
      out += c;
  }
  return out + "'";
}

// A path as a gnuplot string literal.
std::string Q(const fs::path& p) {
  return Literal(p.string());
}

// `text` with every `from` replaced by `to`.
std::string ReplaceAll(std::string text, const std::string& from, const std::string& to) {
  for (std::size_t at = text.find(from); at != std::string::npos;
       at = text.find(from, at + to.size()))
    text.replace(at, from.size(), to);
  return text;
}

// Writes the script beside its figures and runs it there. The script names its files relative
// to its own folder, so that `cd FOLDER && gnuplot NAME.gp` draws them again (after editing a
// label, say); it draws every figure twice: PNG for the screen, SVG for print.
void RunGnuplot(const std::string& script, const fs::path& script_path) {
  const fs::path folder = script_path.parent_path();
  const std::string quoted_folder = Literal((folder / "").string());  // 'FOLDER/'
  const std::string relative =
      ReplaceAll(script, quoted_folder.substr(0, quoted_folder.size() - 1), "'");
  const std::string vector = ReplaceAll(
      ReplaceAll(relative, "set terminal pngcairo", "set terminal svg dynamic"), ".png'", ".svg'");
  // A new file, closed to others' writing, renamed into place: a script another account could
  // edit between its writing and gnuplot's reading would run as this user.
  const report::ClosedToOthersWriting closed;
  report::WriteFileAtomically(script_path,
                              relative + "\n# The same figures as SVG, for print.\n" + vector);
  const ProgramResult gnuplot = RunProgram(
      {"gnuplot", "-e", "cd " + Literal(folder.string()), script_path.filename().string()});
  if (gnuplot.exit_code != 0)
    throw std::runtime_error("gnuplot failed on " + script_path.string() + ": " + gnuplot.output);
}

// Whether a CSV file has a row after its header.
bool HasRows(const fs::path& csv) {
  std::ifstream in(csv);
  std::string line;
  return std::getline(in, line) && std::getline(in, line) && !line.empty();
}

// The values of column `k` (0-based) of a CSV file after its header, finite ones only.
std::vector<double> Column(const fs::path& csv, int k) {
  std::ifstream in(csv);
  std::string line;
  std::vector<double> values;
  std::getline(in, line);
  while (std::getline(in, line)) {
    std::istringstream fields(line);
    std::string field;
    for (int c = 0; c <= k && std::getline(fields, field, ','); ++c) {
      if (c < k) continue;
      char* end = nullptr;
      const double v = std::strtod(field.c_str(), &end);
      if (end != field.c_str() && std::isfinite(v)) values.push_back(v);
    }
  }
  return values;
}

// The largest value of a column (0 for none).
double ColumnMax(const fs::path& csv, int k) {
  const std::vector<double> v = Column(csv, k);
  return v.empty() ? 0.0 : *std::max_element(v.begin(), v.end());
}

// The smallest step between the distinct values of a column: a grid's spacing (1 cm if none).
double ColumnSpacing(const fs::path& csv, int k) {
  std::vector<double> v = Column(csv, k);
  std::sort(v.begin(), v.end());
  double step = 0.0;
  for (std::size_t i = 1; i < v.size(); ++i)
    if (const double d = v[i] - v[i - 1]; d > 1e-12 && (step == 0.0 || d < step)) step = d;
  return step > 0.0 ? step : 0.01;
}

// A number from a JSON file for a script: finite, else the fallback.
double Number(const nlohmann::json& j, const char* key, double fallback) {
  const double v = j.contains(key) && j[key].is_number() ? j[key].get<double>() : fallback;
  return std::isfinite(v) ? v : fallback;
}

nlohmann::json ReadJson(const fs::path& p) {
  std::ifstream in(p);
  return nlohmann::json::parse(in);
}

// An axis label for a scene field, from the field table: its help text and unit, then its
// name ("initial downward speed V0 [m/s] (projectile.speed_m_s)").
std::string FieldLabel(const std::string& name) {
  const SceneField* field = FindSceneField(name);
  if (!field) return name;
  std::string label(field->help);
  if (!field->unit.empty()) label += " [" + std::string(field->unit) + "]";
  return label + " (" + name + ")";
}

// A using-expression for an error bar from column `column` times `scale`. A point of one seed
// has no sd (an empty cell) and is drawn without a bar: gnuplot drops a row whose numeric
// column is empty, so the cell is read as text.
std::string ErrorBar(const std::string& column, double scale) {
  std::ostringstream s;
  s << "(strlen(strcol(" << column << ")) > 0 ? column(" << column << ")*" << scale << " : 0)";
  return s.str();
}

// A number rounded for a title or a label: `digits` significant digits.
std::string Rounded(double v, int digits = 3) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.*g", digits, v);
  return buf;
}

// The numbers of a run's titles as its report prints them (run_command.cpp), so that a figure
// and the report never disagree in the last digit: H to 0.01 cm, forces to 4 significant
// digits, lambda to 0.1%.
std::string Fixed(double v, int decimals) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}
std::string ReportedCm(double metres) {
  return Fixed(100 * metres, 2);
}
std::string ReportedKn(double newtons) {
  return Rounded(newtons / 1e3, 4);
}

// When a snapshot was taken, for its pictures' titles, from its snapshot.json: "0.5 ms after
// the first contact", "at the peak plate force, 1.41 ms after the first contact", "at t = 57.2
// ms"; else its folder's name.
std::string SnapshotTitle(const fs::path& snap) {
  nlohmann::json j;
  try {
    j = ReadJson(snap / "snapshot.json");
  } catch (const std::exception&) {
    return "(" + snap.filename().string() + ")";
  }
  const bool peak = j.value("label", "") == "peak";
  const double after = Number(j, "t_after_contact_s", std::nan(""));
  std::string text = peak ? "at the peak plate force" : "";
  if (std::isfinite(after))
    return text + (peak ? ", " : "") + Rounded(after * 1e3) + " ms after the first contact";
  return text + (peak ? ", " : "") + "at t = " + Rounded(Number(j, "t_s", 0.0) * 1e3) + " ms";
}

// The bead-bead contacts of a snapshot: how many, their mean and largest normal force, and the
// highest bead centre among them (the bed's top, for the picture's frame).
struct ChainStats {
  long count = 0;
  double mean_N = 0.0, max_N = 0.0, top_m = 0.0;
  /// The line widths' classes among the contacts above the mean: their 50th, 80th and 95th
  /// percentiles of force.
  double q50_N = 0.0, q80_N = 0.0, q95_N = 0.0;
};

ChainStats ReadChainStats(const fs::path& contacts_csv) {
  ChainStats stats;
  std::ifstream in(contacts_csv);
  std::string line;
  std::getline(in, line);
  double sum = 0.0;
  std::vector<double> forces;
  while (std::getline(in, line)) {
    std::vector<std::string> cells;
    std::istringstream row(line);
    for (std::string cell; std::getline(row, cell, ',');) cells.push_back(cell);
    auto is_bead = [](const std::string& id) {
      return !id.empty() && std::all_of(id.begin(), id.end(), ::isdigit);
    };
    if (cells.size() < 15 || !is_bead(cells[0]) || !is_bead(cells[1])) continue;
    const double f = std::atof(cells[8].c_str());
    forces.push_back(f);
    sum += f;
    ++stats.count;
    stats.max_N = std::max(stats.max_N, f);
    stats.top_m =
        std::max({stats.top_m, std::atof(cells[11].c_str()), std::atof(cells[14].c_str())});
  }
  stats.mean_N = stats.count ? sum / stats.count : 0.0;
  std::vector<double> above;  // the contacts drawn
  for (double f : forces)
    if (f > stats.mean_N) above.push_back(f);
  std::sort(above.begin(), above.end());
  auto quantile = [&](double q) {
    return above.empty()
               ? stats.mean_N
               : above[static_cast<std::size_t>(q * static_cast<double>(above.size() - 1))];
  };
  stats.q50_N = quantile(0.5);
  stats.q80_N = quantile(0.8);
  stats.q95_N = quantile(0.95);
  return stats;
}

// Force chains as the paper draws them: bead-bead contacts above the mean force, as lines
// between the bead centres, coloured by force and wider by force class, (left) in a vertical
// slice through the axis of width `slab` and (right) seen from above. The projectile's
// contacts are drawn apart, black and dashed, outside the colour scale (they carry hundreds of
// newtons against a bead mean near one); the projectile is its outline in the slice.
std::string ForceChainScript(const fs::path& snap, const ChainStats& chains, double radius,
                             double slab, const std::string& when) {
  nlohmann::json j;
  try {
    j = ReadJson(snap / "snapshot.json");
  } catch (const std::exception&) {
  }
  const nlohmann::json proj = j.value("projectile", nlohmann::json::object());
  const bool has_projectile = proj.is_object() && proj.contains("z_m");
  const double R = 100 * radius, half = 50 * slab, mean = chains.mean_N;
  const double top = 100 * chains.top_m + 0.5;
  const double pz = 100 * Number(proj, "z_m", 0.0), pr = 100 * Number(proj, "radius_m", 0.0);
  const double z_max = std::max(top, has_projectile ? std::min(pz + pr, top + 2 * pr) : top);
  const std::string data = Q(snap / "contacts.csv");
  // Bead-bead rows only: a column that is not a number ("projectile", "plate") drops the row.
  const std::string bead_pair = "($1 >= 0 && $2 >= 0)";
  const std::string in_slab =
      "(abs($11*100) < " + Rounded(half, 6) + " && abs($14*100) < " + Rounded(half, 6) + ")";
  // Line widths by quantile of the contacts drawn: the half below the median, then up to the
  // 80th and 95th percentiles, then the strongest 5%.
  const double bounds[] = {mean, chains.q50_N, chains.q80_N, chains.q95_N, 1e300};
  // The slice above the top view, each panel as tall as its frame is for the same width, so
  // that no canvas is left blank: panel heights in pixels (plot area plus labels).
  constexpr double kWidth = 1000, kPlotWidth = 760, kPanelMargin = 95, kTitle = 60;
  const double slice_px = kPlotWidth * z_max / (2 * R) + kPanelMargin;
  const double top_px = kPlotWidth + kPanelMargin;
  const double height = slice_px + top_px + kTitle;
  std::ostringstream gp;
  gp << kTerminal << "set terminal pngcairo size " << kWidth << "," << static_cast<int>(height)
     << " font 'DejaVu Sans,11'\nset output " << Q(snap / "force_chains.png") << "\n"
     << "set multiplot title " << Literal("force chains " + when) << " . \"\\n\" . "
     << Literal("bead-bead contacts above the mean " + Rounded(mean, 2) + " N (largest " +
                Rounded(chains.max_N, 3) + " N); the projectile's contacts dashed")
     << "\nset size ratio -1\nset key off\n"
     // A logarithmic colour scale from the mean to the largest force: chains of hundreds of
     // newtons and of a few share one figure, every decade its colours.
     << "set cblabel " << Literal("normal force [N], line width by quantile (50, 80, 95%)")
     << "\nset logscale cb\nset cbrange [" << mean << ":" << std::max(chains.max_N, 1.01 * mean)
     << "]\nset cbtics (" << Literal(Rounded(mean, 2)) << " " << mean << ", "
     << Literal(Rounded(chains.q50_N, 2)) << " " << chains.q50_N << ", "
     << Literal(Rounded(chains.q80_N, 2)) << " " << chains.q80_N << ", "
     << Literal(Rounded(chains.q95_N, 2)) << " " << chains.q95_N << ", "
     << Literal(Rounded(chains.max_N, 3)) << " " << chains.max_N << ")\n"
     << "set palette defined (0 '#f2c14e', 0.4 '#e07020', 0.75 '#b01010', 1 '#300000')\n";
  auto layers = [&](const std::string& x, const std::string& y, const std::string& dx,
                    const std::string& dy, const std::string& keep) {
    std::ostringstream p;
    for (int k = 0; k < 4; ++k)
      p << (k ? ", " : "") << data << " every ::1 using ((" << bead_pair << " && " << keep
        << " && $9 > " << bounds[k] << " && $9 <= " << bounds[k + 1] << ") ? " << x
        << " : 1/0):" << y << ":" << dx << ":" << dy << ":9 with vectors nohead lw "
        << 0.8 + 1.1 * k << " lc palette";
    return p.str();
  };
  // Left: the slice, x against z.
  gp << "set origin 0," << top_px / height << "\nset size 1," << slice_px / height << "\n"
     << "set title "
     << Literal("vertical slice through the axis, |y| < " + Rounded(half, 2) + " cm")
     << "\nset xlabel 'x [cm]'\nset ylabel 'z [cm]'\n"
     << "set xrange [" << -R << ":" << R << "]\nset yrange [0:" << z_max << "]\n";
  if (has_projectile && pz - pr < z_max)
    gp << "set object 1 circle at " << 100 * Number(proj, "x_m", 0.0) << "," << pz << " size " << pr
       << " front fs empty border lc rgb '#000000' lw 1.5\n";
  gp << "plot " << layers("($10*100)", "($12*100)", "(($13-$10)*100)", "(($15-$12)*100)", in_slab)
     << ", " << data << " every ::1 using (strcol(1) eq 'projectile' && abs($14*100) < "
     << Rounded(half, 6)
     << " ? $10*100 : 1/0):($12*100):(($13-$10)*100):(($15-$12)*100) with vectors nohead lw 1.5 "
        "dt 2 lc rgb '#000000'\n"
     << "unset object 1\n";
  // Right: the top view, x against y, every depth.
  gp << "set origin 0,0\nset size 1," << top_px / height << "\n"
     << "set title 'seen from above (all depths)'\nset xlabel 'x [cm]'\nset ylabel 'y [cm]'\n"
     << "set xrange [" << -R << ":" << R << "]\nset yrange [" << -R << ":" << R << "]\n"
     << "set object 2 circle at 0,0 size " << R << " fs empty border lc rgb '#808080'\n"
     << "plot " << layers("($10*100)", "($11*100)", "(($13-$10)*100)", "(($14-$11)*100)", "1")
     << "\nunset multiplot\n";
  return gp.str();
}

// F(t) around the impact, in ms after the first contact and kN, with the peaks marked, and the
// same impact on the bare plate (run for lambda) beside it when the run has a bed.
fs::path PlotForceCurve(const fs::path& dir, const nlohmann::json& s) {
  const double contact = Number(s, "first_contact_time_s", 0.0);
  const double end = Number(s, "end_time_s", contact + 0.02);
  const double H = report::MeasuredThickness(s);
  const double P = Number(s, "P_N", 0.0), P0 = Number(s, "reference_peak_N", 0.0);
  const fs::path bare = dir / report::run_files::kPlateForceBare;
  const bool with_bare = H > 0.0 && HasRows(bare);
  std::string title = H > 0.0
                          ? "impact on a " + ReportedCm(H) + " cm bed: P = " + ReportedKn(P) +
                                " kN, bare plate " + ReportedKn(P0) +
                                " kN, lambda = " + Fixed(100 * Number(s, "lambda", 0.0), 1) + "%"
                          : "impact on the bare plate: P = " + ReportedKn(P) + " kN";
  std::ostringstream gp;
  gp << kTerminal << "set output " << Q(dir / "plate_force.png") << "\n"
     << "set xlabel 'time after first contact [ms]'\nset ylabel 'bottom-plate force [kN]'\n"
     << "set title " << Literal(title)
     << "\n"
     // Room on the right for the label of a peak at the end.
     << "set xrange [-0.5:" << (end - contact) * 1.12e3 << "]\n";
  // Every peak is marked; the largest Pa and the largest Pb (the summary's) are labelled.
  const nlohmann::json peaks = s.value("peaks", nlohmann::json::array());
  for (const auto& p : peaks.is_array() ? peaks : nlohmann::json::array()) {
    if (!p.is_object() || !p.contains("kind") || !p["kind"].is_string()) continue;
    const std::string kind = p["kind"].get<std::string>();
    const double force = Number(p, "force_N", 0.0);
    const bool main_peak = force == Number(s, (kind + "_N").c_str(), -1.0);
    gp << "set label " << Literal(main_peak ? kind + " " + ReportedKn(force) + " kN" : "") << " at "
       << (Number(p, "time_s", 0.0) - contact) * 1e3 << "," << force / 1e3
       << " offset 0.6,0.6 point pt 7 ps " << (main_peak ? 1.2 : 0.7) << "\n";
  }
  // A bed that takes most of the force: the bare plate's spike would flatten its curve, so the
  // scale follows the bed's and the spike runs off it.
  const bool bare_off_scale = with_bare && P < 0.3 * P0;
  if (bare_off_scale) gp << "set yrange [0:" << 1.5 * P / 1e3 << "]\n";
  gp << "plot " << Q(dir / report::run_files::kPlateForce) << " every ::1 using (($1-" << contact
     << ")*1e3):($2/1e3) with lines lw 2 lc rgb '#1f4e9c' title "
     << Literal(H > 0.0 ? "on the bed" : "bare plate");
  if (with_bare)
    gp << ", " << Q(bare) << " every ::1 using (($1-"
       << Number(s, "reference_first_contact_time_s", contact)
       << ")*1e3):($2/1e3) with lines lw 1.5 dt 2 lc rgb '#808080' title "
       << Literal(bare_off_scale ? "bare plate (peak " + ReportedKn(P0) + " kN, off the scale)"
                                 : "bare plate");
  gp << "\n";
  RunGnuplot(gp.str(), dir / "plate_force.gp");
  return dir / "plate_force.png";
}

// The projectile in the bed: its speed and how deep its lowest point is below the surface,
// with the times of Pb and Pa, which are where dS and dt are measured. None for a bare plate.
std::optional<fs::path> PlotProjectileInBed(const fs::path& dir, const nlohmann::json& s) {
  const double contact = Number(s, "first_contact_time_s", 0.0);
  const double end = Number(s, "end_time_s", contact + 0.02);
  const double H = report::MeasuredThickness(s);
  const nlohmann::json scene = s.value("scene", nlohmann::json::object());
  const double radius =
      0.5 * Number(scene.value("projectile", nlohmann::json::object()), "diameter_m", 0.0);
  if (!(H > 0.0 && radius > 0.0)) return std::nullopt;
  std::ostringstream pj;
  pj << kTerminal << "set output " << Q(dir / "projectile.png") << "\n"
     << "set xlabel 'time after first contact [ms]'\nset ylabel 'projectile speed [m/s]'\n"
     << "set y2label 'depth of its lowest point below the surface [cm]'\nset y2tics\n"
     << "set ytics nomirror\nset yrange [0:*]\nset y2range [*:*] reverse\nset key top center\n"
     << "set title " << Literal("the projectile in a " + ReportedCm(H) + " cm bed") << "\n"
     << "set xrange [-0.5:" << (end - contact) * 1.12e3 << "]\n";
  for (const char* peak : {"Pb", "Pa"}) {
    const std::string key = std::string(peak) + "_time_s";
    if (!s.contains(key) || !s[key].is_number()) continue;
    const double t = (s[key].get<double>() - contact) * 1e3;
    pj << "set arrow from " << t << ", graph 0 to " << t << ", graph 1 nohead dt 3 lc rgb "
       << "'#808080'\nset label " << Literal(peak) << " at " << t << ", graph 0.95 offset 0.4,0\n";
  }
  pj << "plot " << Q(dir / report::run_files::kPlateForce) << " every ::1 using (($1-" << contact
     << ")*1e3):(abs($5)) with lines lw 2 lc rgb '#1f4e9c' title 'speed', "
     << Q(dir / report::run_files::kPlateForce) << " every ::1 using (($1-" << contact
     << ")*1e3):((" << H << "-($4-" << radius
     << "))*100) axes x1y2 with lines lw 1.5 dt 2 lc rgb '#c05000' "
     << "title 'depth'\n";
  RunGnuplot(pj.str(), dir / "projectile.gp");
  return dir / "projectile.png";
}

// The snapshots: force chains (a vertical slice through the axis and a top view), the
// contact-force PDF, the radial plate load and the plate's map.
std::vector<fs::path> PlotSnapshots(const fs::path& dir, const nlohmann::json& s) {
  std::vector<fs::path> out;
  if (fs::is_directory(dir / "snapshots")) {
    const nlohmann::json scene = s.value("scene", nlohmann::json::object());
    const double radius =
        Number(scene.value("cylinder", nlohmann::json::object()), "radius_m", 0.1);
    const double slab =
        Number(scene.value("output", nlohmann::json::object()), "chain_slab_width_m", 0.009);
    for (const auto& entry : fs::directory_iterator(dir / "snapshots")) {
      const fs::path snap = entry.path();
      if (!fs::exists(snap / "contacts.csv")) continue;
      const std::string when = SnapshotTitle(snap);
      // Without bead contacts (a bare plate) there are no chains and no force statistics.
      if (const ChainStats chains = ReadChainStats(snap / "contacts.csv"); chains.count > 0) {
        RunGnuplot(ForceChainScript(snap, chains, radius, slab, when), snap / "force_chains.gp");
        out.push_back(snap / "force_chains.png");
      }

      if (HasRows(snap / "force_pdf.csv")) {
        // On log-log axes, as the paper's Fig. 16: the strong forces' tail, decades below the
        // peak of the density, stays visible.
        std::ostringstream pdf;
        pdf << kTerminal << "set output " << Q(snap / "force_pdf.png") << "\n"
            << "set xlabel 'f / <f>'\nset ylabel 'probability density'\nset logscale xy\n"
            << "set format y '10^{%T}'\nset termoption enhanced\n"
            << "set title " << Literal("bead-bead contact forces " + when) << " noenhanced\n"
            << "plot " << Q(snap / "force_pdf.csv")
            << " every ::1 using 1:($2 > 0 ? $2 : 1/0) with linespoints pt 7 title 'bead-bead'\n";
        RunGnuplot(pdf.str(), snap / "force_pdf.gp");
        out.push_back(snap / "force_pdf.png");
      }

      // The pressure in the unit that reads: MPa under the projectile's strike, kPa else.
      const double max_pressure = ColumnMax(snap / "plate_radial.csv", 3);
      const bool mpa = max_pressure >= 1e6;
      std::ostringstream radial;
      radial << kTerminal << "set output " << Q(snap / "plate_radial.png") << "\n"
             << "set xlabel 'radius [cm]'\nset ylabel 'plate pressure [" << (mpa ? "MPa" : "kPa")
             << "]'\nset title " << Literal("load on the bottom plate by ring " + when) << "\n"
             << "plot " << Q(snap / "plate_radial.csv") << " every ::1 using (($1+$2)*50):($4/"
             << (mpa ? "1e6" : "1e3") << ") with histeps lw 2 title 'pressure'\n";
      RunGnuplot(radial.str(), snap / "plate_radial.gp");
      out.push_back(snap / "plate_radial.png");

      // The force on each plate cell, seen from above (the paper's Fig. 15).
      if (HasRows(snap / "plate_map.csv")) {
        const double cell_cm = 100 * ColumnSpacing(snap / "plate_map.csv", 0);
        std::ostringstream map;
        map << kTerminal << "set terminal pngcairo size 760,640 font 'DejaVu Sans,12'\n"
            << "set output " << Q(snap / "plate_map.png") << "\n"
            << "set size ratio -1\nset xlabel 'x [cm]'\nset ylabel 'y [cm]'\n"
            << "set cblabel 'force on the cell [N]'\nset palette defined (0 'white', 1 '#fdd49e', "
               "2 '#fc8d59', 3 '#d7301f', 4 '#7f0000')\nset cbrange [0:*]\n"
            << "set title 'force on the bottom plate by cell' . \"\\n\" . " << Literal(when) << "\n"
            << "plot " << Q(snap / "plate_map.csv") << " every ::1 using ($1*100):($2*100):("
            << cell_cm / 2 << "):(" << cell_cm / 2
            << "):3 with boxxyerror fs solid 1.0 noborder lc palette notitle\n";
        RunGnuplot(map.str(), snap / "plate_map.gp");
        out.push_back(snap / "plate_map.png");
      }
    }
  }
  return out;
}

// A run's plots: F(t), the projectile in the bed, and each snapshot's.
std::vector<fs::path> PlotRun(const fs::path& dir) {
  const nlohmann::json s = ReadJson(dir / report::run_files::kSummary);
  std::vector<fs::path> out = {PlotForceCurve(dir, s)};
  if (const std::optional<fs::path> projectile = PlotProjectileInBed(dir, s))
    out.push_back(*projectile);
  for (const fs::path& plot : PlotSnapshots(dir, s)) out.push_back(plot);
  return out;
}

// F(t) of every run of a sweep, aligned at first contact: a colour per point, its seeds
// alike. None without a finished run.
std::optional<fs::path> PlotSweepCurves(const fs::path& dir) {
  std::ostringstream curves;
  curves << kTerminal << "set output " << Q(dir / "sweep_curves.png") << "\n"
         << "set xlabel 'time after first contact [ms]'\nset ylabel 'plate force [kN]'\n"
         << "set title 'bottom-plate force, every seed (a colour per point)'\n"
         << "set palette defined (0 '#440154', 0.33 '#31688e', 0.66 '#35b779', 1 '#e3a000')\n"
         << "unset colorbox\nset xrange [-0.5:*]\nplot ";
  bool first = true;
  std::vector<fs::path> runs;
  for (const auto& e : fs::directory_iterator(dir / "runs")) runs.push_back(e.path());
  std::sort(runs.begin(), runs.end());
  auto point_of = [](const fs::path& run) {
    std::string point = run.filename().string();
    point = point.substr(point.find('_') + 1);
    return point.substr(0, point.rfind("_seed="));
  };
  std::map<std::string, int> colour;  // point -> its place along the palette
  for (const fs::path& run : runs) colour.try_emplace(point_of(run), 0);
  int place = 0;
  for (auto& [point, k] : colour) k = place++;
  // A colour per point along one palette (not the 8 line types, which repeat).
  std::set<std::string> titled;
  for (const fs::path& run : runs) {
    if (!fs::exists(run / report::run_files::kSummary)) continue;
    const nlohmann::json s = ReadJson(run / report::run_files::kSummary);
    const std::string point = point_of(run);
    const double t0 = Number(s, "first_contact_time_s", 0.0);
    const double frac = colour.size() > 1 ? colour[point] / (colour.size() - 1.0) : 0.0;
    curves << (first ? "" : ", ") << Q(run / report::run_files::kPlateForce)
           << " every ::1 using (($1-" << t0 << ")*1e3):($2/1e3) with lines lw 1.2 lc palette frac "
           << frac << " "
           << (titled.insert(point).second ? "title " + Literal(point) : std::string("notitle"));
    first = false;
  }
  curves << "\n";
  if (first) return std::nullopt;
  RunGnuplot(curves.str(), dir / "sweep_curves.gp");
  return dir / "sweep_curves.png";
}

// A sweep over one field: P, Pa, Pb, lambda, crater depth, dS and dt against it, and the
// F(t) curves of every run, aligned at first contact.
std::vector<fs::path> PlotSweep(const fs::path& dir) {
  std::vector<fs::path> out;
  // The header, then the sweep's points. A metric is plotted only where some point has it (a
  // bare plate has no Pb, a thin bed no dS): gnuplot refuses a plot whose every series is empty.
  std::ifstream points(dir / sweep_files::kPoints);
  std::vector<std::vector<std::string>> rows;
  for (std::string line; std::getline(points, line);) {
    std::vector<std::string> row;
    std::istringstream cells(line);
    for (std::string c; std::getline(cells, c, ',');) row.push_back(c);
    rows.push_back(std::move(row));
  }
  if (rows.empty()) throw std::runtime_error("points.csv is empty");
  const std::vector<std::string>& columns = rows.front();
  auto index = [&](const std::string& name) {
    const auto at = std::find(columns.begin(), columns.end(), name);
    if (at == columns.end()) throw std::runtime_error("points.csv has no column " + name);
    return static_cast<std::size_t>(at - columns.begin());
  };
  auto col = [&](const std::string& name) { return std::to_string(index(name) + 1); };
  auto has_data = [&](const std::string& metric) {
    const std::size_t k = index(metric);
    return std::any_of(rows.begin() + 1, rows.end(),
                       [&](const auto& row) { return k < row.size() && !row[k].empty(); });
  };
  const std::string field = columns.at(0);
  const bool thickness = field == "bed.thickness_m";
  const std::string x = thickness ? "($1*100)" : "1";
  const std::string xlabel = thickness ? "bed thickness H [cm]" : FieldLabel(field);
  const fs::path data = dir / sweep_files::kPoints;
  // Each series its own marker; `style` adds a line type or a marker size.
  auto series = [&](const std::string& metric, double scale, const std::string& title,
                    const std::string& style = "pt 7") {
    std::ostringstream s;
    s << Q(data) << " every ::1 using " << x << ":($" << col(metric) << "*" << scale
      << "):" << ErrorBar(col(metric + "_sd"), scale) << " with yerrorlines lw 1.5 " << style
      << " title " << Literal(title);
    return s.str();
  };
  std::ostringstream gp;
  // Room at the frame for the end markers, and error bars with visible caps.
  gp << kTerminal << "set offsets graph 0.03, graph 0.03, graph 0.06, graph 0.06\nset bars 2\n"
     << "set xlabel " << Literal(xlabel) << "\n"
     << "set output " << Q(dir / "sweep_peaks.png") << "\nset ylabel 'force [kN]'\n"
     << "set yrange [0:*]\n"  // a force: the offsets' room below zero shows nothing
     << "set title 'peak plate force (mean +- sd over seeds)'\nplot ";
  // Pa and Pb first, dashed with filled markers; P (the larger of them) on top, open and
  // larger, so that it shows where it is Pa.
  for (const auto& [peak, style] :
       {std::pair{"Pa", "dt 2 pt 5 ps 0.9"}, {"Pb", "dt 3 pt 9 ps 1.1"}})
    if (has_data(std::string(peak) + "_N"))
      gp << series(std::string(peak) + "_N", 1e-3, peak, style) << ", ";
  gp << series("P_N", 1e-3, "P", "pt 6 ps 1.8 lc rgb 'black'") << "\n"
     << "set autoscale y\n"
     << "set output " << Q(dir / "sweep_lambda.png") << "\nset ylabel 'buffer ratio lambda [%]'\n"
     << "set title 'buffer ratio'\nplot " << series("lambda", 100, "lambda") << "\n"
     << "set output " << Q(dir / "sweep_crater.png") << "\nset ylabel 'crater depth [cm]'\n"
     << "set title 'crater depth'\nplot " << series("crater_depth_m", 100, "crater depth") << "\n";
  // dS and dt exist where both peaks were found (dt comes with dS).
  const bool two_peaks = thickness && has_data("dS_m");
  if (two_peaks)
    gp << "set output " << Q(dir / "sweep_ds_dt.png") << "\nset ylabel 'dS [cm]'\n"
       << "set y2label 'dt [ms]'\nset y2tics\nset title 'travel and time between Pb and Pa'\n"
       << "plot " << series("dS_m", 100, "dS") << ", " << Q(data) << " every ::1 using " << x
       << ":($" << col("dt_peaks_s") << "*1e3):" << ErrorBar(col("dt_peaks_s_sd"), 1e3)
       << " axes x1y2 with yerrorlines pt 5 title 'dt'\n"
       << "unset y2tics\nunset y2label\n";
  RunGnuplot(gp.str(), dir / "sweep.gp");
  for (const char* name : {"sweep_peaks.png", "sweep_lambda.png", "sweep_crater.png"})
    out.push_back(dir / name);
  if (two_peaks) out.push_back(dir / "sweep_ds_dt.png");
  if (const std::optional<fs::path> curves = PlotSweepCurves(dir)) out.push_back(*curves);
  return out;
}

}  // namespace

std::filesystem::path PlotComparison(const fs::path& dir, double hertz_peak_N, double h_max_m,
                                     const std::vector<std::string>& variant) {
  std::string title = "dembuf (mean +- sd over seeds) beside the paper (E2)";
  if (!variant.empty()) {
    title = "dembuf, E2 with";
    for (const std::string& v : variant) title += " " + v;
    title += " (not the paper's stated model), beside the paper";
  }
  const fs::path data = dir / "compare_points.csv";
  // The paper's E2: Pa0 13.46 kN, P 6.73 kN and lambda 50% at 0.8 cm, lambda 84% (P levels off)
  // from Hc ~ 2 cm (MODEL.md section 5).
  const double plateau_kN = 13.46 * (1 - 0.84);
  std::ostringstream gp;
  gp << kTerminal << "set terminal pngcairo size 1200,1000 font 'DejaVu Sans,11'\n"
     << "set output " << Q(dir / "compare.png") << "\n"
     << "$paper << EOD\n0,13.46,0\n0.8,6.73,50\nEOD\n"
     << "set multiplot layout 2,2 title " << Literal(title) << "\n"
     << "set xlabel 'bed thickness H [cm]'\nset ylabel 'peak plate force P [kN]'\n"
     << "set xrange [-0.2:" << std::max(100 * h_max_m, 2.5) + 0.3 << "]\nset yrange [0:*]\n"
     << "plot " << Q(data) << " every ::1 using ($1*100):($2/1e3):" << ErrorBar("3", 1e-3)
     << " with yerrorlines pt 7 lw 1.5 title 'dembuf P', " << Q(data) << " every ::1 using "
     << "($1*100):($10/1e3):" << ErrorBar("11", 1e-3)
     << " with yerrorlines pt 9 dt 3 lw 1.2 lc rgb '#2a9d8f' title 'dembuf Pb (strike)', "
     << "$paper using 1:2 with points pt 5 ps 1.6 lc rgb '#d02000' title 'paper', "
     << "[2:*] " << plateau_kN
     << " with lines dt 2 lw 1.5 lc rgb '#d02000' title 'paper: plateau (P = Pb) from Hc ~ 2 cm', "
     << "'+' using (0):(" << hertz_peak_N / 1e3
     << ") every ::0::0 with points pt 4 ps 1.6 lc rgb '#606060' title 'Hertz, no damping'\n"
     << "set ylabel 'buffer ratio lambda [%]'\nset yrange [0:100]\nset key bottom right\n"
     << "plot " << Q(data) << " every ::1 using ($1*100):($4*100):" << ErrorBar("5", 100)
     << " with yerrorlines pt 7 lw 1.5 title 'dembuf', $paper using 1:3 with points pt 5 ps 1.6 "
        "lc rgb '#d02000' title 'paper', [2:*] 84 with lines dt 2 lw 1.5 lc rgb '#d02000' "
        "title 'paper: plateau'\n"
     // Between the peaks: the paper's fits (H in cm), where they are positive.
     << "set key top left\nset yrange [0:*]\nset xrange [0:" << std::max(100 * h_max_m, 2.5) + 0.3
     << "]\nset ylabel 'projectile travel dS between Pb and Pa [cm]'\n"
     << "plot " << Q(data) << " every ::1 using ($1*100):($6*100):" << ErrorBar("7", 100)
     << " with yerrorlines pt 7 lw 1.5 title 'dembuf', [0.36:*] 0.91*x - 0.32 with lines dt 2 "
        "lw 1.5 lc rgb '#d02000' title 'paper: fit 0.91 H - 0.32'\n"
     << "set ylabel 'time dt between Pb and Pa [ms]'\n"
     << "plot " << Q(data) << " every ::1 using ($1*100):($8*1e3):" << ErrorBar("9", 1e3)
     << " with yerrorlines pt 7 lw 1.5 title 'dembuf', [0.86:3.5] 5.43*x - 4.65 with lines dt 2 "
        "lw 1.5 lc rgb '#d02000' title 'paper: fit 5.43 H - 4.65 (H < 3.5 cm)', [3.5:*] "
        "10.36*x - 21.61 with lines dt 4 lw 1.5 lc rgb '#d02000' title 'paper: fit 10.36 H - "
        "21.61'\n"
     << "unset multiplot\n";
  RunGnuplot(gp.str(), dir / "compare.gp");
  return dir / "compare.png";
}

bool GnuplotAvailable() {
  return RunProgram({"gnuplot", "--version"}).exit_code == 0;
}

std::vector<fs::path> PlotFolder(const fs::path& dir) {
  if (fs::exists(dir / sweep_files::kPoints)) return PlotSweep(dir);
  if (fs::exists(dir / report::run_files::kPlateForce) &&
      fs::exists(dir / report::run_files::kSummary))
    return PlotRun(dir);
  throw std::runtime_error(dir.string() +
                           " holds neither a run (plate_force.csv, summary.json) "
                           "nor a sweep (points.csv)");
}

// Plots a finished run or sweep when gnuplot is there; a missing gnuplot is not an error.
void PlotIfPossible(const std::filesystem::path& dir) {
  if (!GnuplotAvailable()) {
    std::printf("plots: skipped (install gnuplot-nox, then: dembuf plot %s)\n", dir.c_str());
    return;
  }
  try {
    const auto files = PlotFolder(dir);
    std::printf("plots: %zu PNG files in %s\n", files.size(), dir.c_str());
  } catch (const std::exception& e) {
    std::printf("plots: failed: %s\n", e.what());
  }
}

}  // namespace dembuf::cli
