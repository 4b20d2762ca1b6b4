#include "dembuf/study/sweep/paper_comparison.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>

#include "dembuf/study/files/run_output.h"
#include "dembuf/study/scene/presets.h"

namespace dembuf {

namespace {

// Fields that do not change the physics the paper describes: the bed's thickness (compared
// point by point), its seed and every knob of how it is made (its accuracy), or imported
// (bed.*, but for the friction it settles with, which sets its packing); the run's times and
// its outputs.
bool IgnoredField(const std::string& name) {
  const bool how_the_bed_is_made = name.rfind("bed.", 0) == 0 && name != "bed.prep_friction";
  return how_the_bed_is_made || name.rfind("time.", 0) == 0 || name.rfind("output.", 0) == 0;
}

// Fields of the mechanisms a study adds to the paper's stated model to explain its curve
// (docs/reproduction.md): runs that differ from E2 only by them are compared with the paper
// as a variant of E2, and say so.
bool VariantField(const std::string& name) {
  return name.rfind("damping.", 0) == 0 || name == "material.density_kg_m3";
}

// The dotted names of the fields where `scene` differs from `reference` (nested JSON). A field
// the scene lacks (a run of a dembuf before the field existed) had its default value there,
// as it has in `defaults` (the default scene's JSON).
void DifferingFields(const nlohmann::json& scene, const nlohmann::json& reference,
                     const nlohmann::json& defaults, const std::string& prefix,
                     std::set<std::string>& out) {
  for (auto it = reference.begin(); it != reference.end(); ++it) {
    const std::string name = prefix.empty() ? it.key() : prefix + "." + it.key();
    if (IgnoredField(name)) continue;
    const bool has_default = defaults.is_object() && defaults.contains(it.key());
    if (!scene.is_object() || !scene.contains(it.key())) {
      if (!has_default || defaults[it.key()] != *it) out.insert(name);
    } else if (it->is_object()) {
      DifferingFields(scene[it.key()], *it,
                      has_default ? defaults[it.key()] : nlohmann::json::object(), name, out);
    } else if (it->is_number() && scene[it.key()].is_number()) {
      const double a = it->get<double>(), b = scene[it.key()].get<double>();
      if (std::abs(a - b) > 1e-12 * std::max(std::abs(a), std::abs(b))) out.insert(name);
    } else if (*it != scene[it.key()]) {
      out.insert(name);
    }
  }
}

double Number(const nlohmann::json& j, const char* key) {
  if (!j.contains(key) || !j[key].is_number())
    throw std::runtime_error(std::string("not a run's summary.json: no number ") + key);
  return j[key].get<double>();
}

// The paper's E2 values for the runs at thickness h (m), SI: {quantity, label, scale, value,
// source}.
struct PaperValue {
  const char* quantity;
  const char* label;
  double scale;
  double value;
  std::string source;
};

std::vector<PaperValue> PaperValues(double h) {
  std::vector<PaperValue> out;
  const double h_cm = 100 * h;
  if (h == 0.0) {
    out.push_back({"P_N", "Pa0, bare plate [kN]", 1e-3, 13.46e3, "E2 without beads"});
    return out;
  }
  if (std::abs(h - 0.008) < 1e-9) {
    out.push_back({"P_N", "P = Pa [kN]", 1e-3, 6.73e3, "E2 at H = 0.8 cm"});
    out.push_back({"lambda", "lambda [%]", 100, 0.50, "E2 at H = 0.8 cm"});
  }
  if (h >= 0.02 - 1e-9) {
    out.push_back({"lambda", "lambda [%]", 100, 0.84, "E2 plateau above Hc ~ 2 cm"});
    // Above 1.75 cm the paper's larger peak is the strike's, Pb: the plateau's P is Pb.
    out.push_back({"Pb_N", "Pb [kN]", 1e-3, 13.46e3 * (1 - 0.84), "E2 plateau: P = Pb above Hc"});
  }
  // The fits between the two peaks (H in cm), where they give a positive value.
  const double ds_cm = 0.91 * h_cm - 0.32;
  if (ds_cm > 0) out.push_back({"dS_m", "dS [cm]", 100, ds_cm / 100, "E2 fit dS = 0.91 H - 0.32"});
  const bool thick = h_cm >= 3.5;
  const double dt_ms = thick ? 10.36 * h_cm - 21.61 : 5.43 * h_cm - 4.65;
  if (dt_ms > 0)
    out.push_back({"dt_peaks_s", "dt [ms]", 1e3, dt_ms / 1e3,
                   thick ? "E2 fit dt = 10.36 H - 21.61" : "E2 fit dt = 5.43 H - 4.65"});
  return out;
}

ComparisonRow MakeRow(const PaperValue& p, double h, const std::vector<double>& values) {
  ComparisonRow row;
  row.quantity = p.quantity;
  row.label = p.label;
  row.scale = p.scale;
  row.h_m = h;
  row.paper = p.value;
  row.source = p.source;
  row.n = static_cast<int>(values.size());
  for (double v : values) row.mean += v / values.size();
  double var = 0.0;
  for (double v : values) var += (v - row.mean) * (v - row.mean);
  row.sd = values.size() > 1 ? std::sqrt(var / (values.size() - 1))
                             : std::numeric_limits<double>::quiet_NaN();
  row.min = *std::min_element(values.begin(), values.end());
  row.max = *std::max_element(values.begin(), values.end());
  row.deviation = row.mean / row.paper - 1.0;
  if (values.size() > 1) row.paper_within_range = row.min <= row.paper && row.paper <= row.max;
  return row;
}

std::string Format(const char* format, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, format, v);
  return buf;
}

}  // namespace

double HertzImpactPeak(double mass_kg, double radius_m, double speed_m_s, double e1_Pa, double nu1,
                       double e2_Pa, double nu2) {
  const double e_star = 1.0 / ((1 - nu1 * nu1) / e1_Pa + (1 - nu2 * nu2) / e2_Pa);
  const double k = 4.0 / 3.0 * e_star * std::sqrt(radius_m);
  return std::pow(k, 0.4) * std::pow(1.25 * mass_kg * speed_m_s * speed_m_s, 0.6);
}

Comparison CompareWithPaper(const std::vector<nlohmann::json>& summaries,
                            std::optional<double> hc_m, double hc_sd_m) {
  Comparison c;
  const nlohmann::json e2 = report::SceneToJson(PresetScene("e2"));
  const nlohmann::json defaults = report::SceneToJson(Scene{});
  std::set<std::string> differs;
  std::map<double, std::vector<const nlohmann::json*>> by_thickness;
  for (const nlohmann::json& s : summaries) {
    if (!s.is_object() || !s.contains("scene") || !s["scene"].is_object())
      throw std::runtime_error("not a run's summary.json: no scene");
    const nlohmann::json& scene = s["scene"];
    DifferingFields(scene, e2, defaults, "", differs);
    const double h = Number(scene.value("bed", nlohmann::json::object()), "thickness_m");
    by_thickness[std::round(h * 1e7) / 1e7].push_back(&s);
  }
  for (const std::string& name : differs) {
    if (!VariantField(name)) {
      c.differs.push_back(name);
      continue;
    }
    // As the first run has it (a sweep of one variant has one value).
    std::string path = "/" + name;
    std::replace(path.begin(), path.end(), '.', '/');
    const nlohmann::json& scene = summaries.front()["scene"];
    const nlohmann::json::json_pointer pointer(path);
    const nlohmann::json* value = scene.contains(pointer) ? &scene[pointer] : nullptr;
    c.variant.push_back(name + " = " + (value ? value->dump() : std::string("?")));
  }
  c.is_paper_e2 = !summaries.empty() && c.differs.empty();
  if (!summaries.empty()) {
    const nlohmann::json& scene = summaries.front()["scene"];
    // A part the summary lacks is empty, not read past (a summary from elsewhere may lack it).
    auto part = [&](const char* key) {
      return scene.contains(key) && scene[key].is_object() ? scene[key] : nlohmann::json::object();
    };
    const nlohmann::json m = part("material");
    const nlohmann::json w = part("walls");
    const bool from_beads = w.value("material_from_beads", true);
    const double e = Number(m, "youngs_modulus_Pa"), nu = Number(m, "poisson_ratio");
    // The speed at first contact by the scene (its fall from height_m to the surface), not
    // as runs measured it: the reference is the same whichever runs are given.
    // (A field an older run does not record had its default.)
    const Scene d;
    const nlohmann::json projectile = part("projectile");
    auto field = [](const nlohmann::json& part, const char* key, double otherwise) {
      return part.contains(key) ? Number(part, key) : otherwise;
    };
    const double radius = 0.5 * field(projectile, "diameter_m", d.projectile.diameter_m);
    const double v0 = field(projectile, "speed_m_s", d.projectile.speed_m_s);
    const double fall =
        std::max(0.0, field(projectile, "height_m", d.projectile.height_m) - radius);
    const double speed =
        std::sqrt(v0 * v0 + 2.0 * field(scene, "gravity_m_s2", d.gravity_m_s2) * fall);
    c.hertz_peak_N = HertzImpactPeak(Number(projectile, "mass_kg"), radius, speed, e, nu,
                                     from_beads ? e : Number(w, "youngs_modulus_Pa"),
                                     from_beads ? nu : Number(w, "poisson_ratio"));
  }
  if (!c.is_paper_e2) return c;
  for (const auto& [h, runs] : by_thickness) {
    for (const PaperValue& p : PaperValues(h)) {
      std::vector<double> values;
      for (const nlohmann::json* s : runs)
        if (s->contains(p.quantity) && (*s)[p.quantity].is_number())
          values.push_back((*s)[p.quantity].get<double>());
      if (!values.empty()) c.rows.push_back(MakeRow(p, h, values));
    }
  }
  if (hc_m) {
    ComparisonRow row =
        MakeRow({"Hc_m", "Hc [cm]", 100, 0.02, "E2 where P levels off"}, 0.0, {*hc_m});
    row.sd = hc_sd_m;
    if (std::isfinite(hc_sd_m)) {
      // Within the uncertainty of the bisection: the mean +- 2 sd.
      row.min = *hc_m - 2 * hc_sd_m;
      row.max = *hc_m + 2 * hc_sd_m;
      row.paper_within_range = row.min <= row.paper && row.paper <= row.max;
    }
    c.rows.push_back(row);
  }
  return c;
}

std::string ComparisonTable(const Comparison& c) {
  std::ostringstream out;
  out << "Hertz peak of the projectile on the bare plate (elastic, no damping): "
      << Format("%.4g", c.hertz_peak_N / 1e3) << " kN\n";
  if (!c.is_paper_e2) {
    out << "no paper numbers for these runs: the paper's E2 impact differs in";
    for (const std::string& f : c.differs) out << " " << f;
    out << "\n";
    return out.str();
  }
  if (!c.variant.empty()) {
    out << "E2 with what the paper does not state:";
    for (const std::string& v : c.variant) out << " " << v;
    out << "\n";
  }
  char line[256];
  std::snprintf(line, sizeof line, "%-22s %6s %9s %28s %10s  %s\n", "quantity", "H [cm]", "paper",
                "dembuf: mean +- sd [range]", "deviation", "paper in the runs' range");
  out << line;
  for (const ComparisonRow& r : c.rows) {
    std::string dembuf = Format("%.4g", r.mean * r.scale);
    if (std::isfinite(r.sd)) dembuf += " +- " + Format("%.2g", r.sd * r.scale);
    if (r.n > 1)
      dembuf +=
          " [" + Format("%.3g", r.min * r.scale) + ", " + Format("%.3g", r.max * r.scale) + "]";
    const std::string within = !r.paper_within_range   ? "- (n = " + std::to_string(r.n) + ")"
                               : *r.paper_within_range ? "yes"
                                                       : "NO: outside";
    std::snprintf(line, sizeof line, "%-22s %6s %9.4g %28s %+9.1f%%  %s\n", r.label.c_str(),
                  r.quantity == "Hc_m" ? "" : Format("%.3g", 100 * r.h_m).c_str(),
                  r.paper * r.scale, dembuf.c_str(), 100 * r.deviation, within.c_str());
    out << line;
  }
  if (c.rows.empty())
    out << "no paper number at these runs' thicknesses: the paper gives P at 0 and 0.8 cm, "
           "lambda at 0.8 cm and from 2 cm on, dS (its fit) from 0.35 cm and dt from 0.86 cm on; "
           "for example dembuf sweep --preset e2 --vary bed.thickness_m=0,0.008,0.02,0.04,0.08\n";
  return out.str();
}

std::string ComparisonCsv(const Comparison& c) {
  std::ostringstream out;
  out.precision(10);
  out << "quantity,H_m,paper,source,n,mean,sd,min,max,deviation,paper_within_range\n";
  for (const ComparisonRow& r : c.rows) {
    out << r.quantity << "," << r.h_m << "," << r.paper << ",\"" << r.source << "\"," << r.n << ","
        << r.mean << ",";
    if (std::isfinite(r.sd)) out << r.sd;
    out << "," << r.min << "," << r.max << "," << r.deviation << ",";
    if (r.paper_within_range) out << (*r.paper_within_range ? "yes" : "no");
    out << "\n";
  }
  // A variant's mechanism, in the source's column, so that the table says what it compares.
  for (const std::string& v : c.variant) {
    std::string quoted;  // CSV: a quote inside a quoted field is doubled
    for (const char ch : v) quoted += ch == '"' ? std::string(2, '"') : std::string(1, ch);
    out << "variant,,,\"" << quoted << "\",,,,,,,\n";
  }
  // The analytic value in the mean's column: it is no measurement of the paper.
  out << "hertz_peak_N,,,\"elastic sphere on the bare plate, no damping\",," << c.hertz_peak_N
      << ",,,,,\n";
  return out.str();
}

}  // namespace dembuf
