// What accuracy costs in time, on the paper's E2 impact (V0 = 5 m/s, M = 0.3 kg) on a 1 cm bed:
// for each accuracy knob, the error of the outputs (peak force P, buffer ratio lambda, time
// from first contact to the peak, crater depth) against the knob's most accurate setting, next
// to the wall time it took. Prints tables (Markdown) and writes JSON.
//
//   dembuf_accuracy_study [--out accuracy.json] [--parts 1,2,3,4]
//
// 1. Time-step factor alpha, 0.025 to 1, on one bed (prepared once at the standard settings):
//    the impact alone. The bed is the same, so the differences are the integration's.
// 2. Settling tolerance 1e-3 to 1e-6: each its own bed, preparation included in the time.
// 3. Bed diameter (cylinder radius 5.5 to 9.5 cm): each its own bed; the paper's 9.5 cm is the
//    reference (smaller cylinders are cheaper; the wall is closer).
// 4. The accuracy presets draft / standard / reference, whole runs (bed and impact), against
//    the reference preset.
// Beds are prepared in memory (nothing cached), on one thread, so that times compare.
#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>

#include "dembuf/study/bed/bed.h"
#include "dembuf/study/impact/impact.h"
#include "dembuf/study/scene/presets.h"

using namespace dembuf;

namespace {

struct Outcome {
  bool ok = false;
  std::string error;
  double p_N = 0, lambda = 0, peak_after_contact_s = 0, crater_m = 0;
  double bed_s = 0, impact_s = 0;  ///< wall times
  long long steps = 0;
};

Scene StudyScene() {
  Scene scene = PresetScene("e2");
  scene.bed.thickness_m = 0.01;
  scene.bed.source_thickness_m = 0.015;
  return scene;
}

Outcome Measure(const Scene& scene, const std::function<void(World&)>& adjust = {},
                BedCache* shared = nullptr) {
  Outcome o;
  try {
    BedCache own;
    const auto t0 = std::chrono::steady_clock::now();
    World world = BuildWorld(scene, shared ? shared : &own);
    const auto t1 = std::chrono::steady_clock::now();
    world.params.threads = 1;
    if (adjust) adjust(world);
    RunControl control;
    const ImpactSummary s = RunImpact(std::move(world), scene, control);
    const auto t2 = std::chrono::steady_clock::now();
    o.ok = true;
    o.p_N = s.peaks.p_N;
    o.lambda = s.lambda;
    o.peak_after_contact_s = s.peaks.p_time_s - s.first_contact_time_s;
    o.crater_m = s.crater_depth_m;
    o.steps = s.steps;
    o.bed_s = std::chrono::duration<double>(t1 - t0).count();
    o.impact_s = std::chrono::duration<double>(t2 - t1).count();
  } catch (const std::exception& e) {
    o.error = e.what();
  }
  return o;
}

double RelativeError(double value, double reference) {
  return reference != 0 ? (value - reference) / reference : 0.0;
}

nlohmann::json Row(const std::string& setting, const Outcome& o, const Outcome& ref,
                   bool with_bed) {
  nlohmann::json row = {{"setting", setting}, {"ok", o.ok}};
  if (!o.ok) {
    row["error"] = o.error;
    std::printf("| %s | failed: %s |\n", setting.c_str(), o.error.c_str());
    return row;
  }
  row.update({{"P_N", o.p_N},
              {"lambda", o.lambda},
              {"peak_after_contact_s", o.peak_after_contact_s},
              {"crater_depth_m", o.crater_m},
              {"err_P", RelativeError(o.p_N, ref.p_N)},
              {"err_lambda_points", o.lambda - ref.lambda},
              {"err_peak_time", RelativeError(o.peak_after_contact_s, ref.peak_after_contact_s)},
              {"err_crater", RelativeError(o.crater_m, ref.crater_m)},
              {"bed_wall_s", o.bed_s},
              {"impact_wall_s", o.impact_s},
              {"steps", o.steps}});
  std::printf(
      "| %s | %.4g | %+.2f%% | %.2f (%+.2f) | %+.2f%% | %+.2f%% | %s%.1f |\n", setting.c_str(),
      o.p_N, 100 * RelativeError(o.p_N, ref.p_N), 100 * o.lambda, 100 * (o.lambda - ref.lambda),
      100 * RelativeError(o.peak_after_contact_s, ref.peak_after_contact_s),
      100 * RelativeError(o.crater_m, ref.crater_m),
      with_bed ? (std::to_string(static_cast<int>(std::lround(o.bed_s))) + " + ").c_str() : "",
      o.impact_s);
  std::fflush(stdout);
  return row;
}

void Header(const char* title, const char* knob, bool with_bed) {
  std::printf(
      "\n%s\n\n| %s | P [N] | error P | lambda [%%] (diff) | error t(P) | error crater | "
      "wall time [s]%s |\n|---|---|---|---|---|---|---|\n",
      title, knob, with_bed ? " (bed + impact)" : " (impact)");
  std::fflush(stdout);
}

std::vector<std::string> Labels(const std::vector<double>& values) {
  std::vector<std::string> labels;
  for (double v : values) {
    char text[32];
    std::snprintf(text, sizeof text, "%g", v);
    labels.emplace_back(text);
  }
  return labels;
}

// Measures every setting of one knob, then prints its table against the setting at
// `reference` and returns it as JSON.
nlohmann::json Study(const char* title, const char* knob, const std::vector<std::string>& settings,
                     std::size_t reference, bool with_bed,
                     const std::function<Outcome(std::size_t)>& measure) {
  std::vector<Outcome> outcomes;
  for (std::size_t k = 0; k < settings.size(); ++k) outcomes.push_back(measure(k));
  Header(title, knob, with_bed);
  nlohmann::json rows = nlohmann::json::array();
  for (std::size_t k = 0; k < settings.size(); ++k)
    rows.push_back(Row(settings[k], outcomes[k], outcomes[reference], with_bed));
  return rows;
}

}  // namespace

int main(int argc, char** argv) {
  std::string out = "accuracy.json";
  std::vector<int> parts = {1, 2, 3, 4};
  CLI::App app{"What accuracy costs in time: each knob's error and wall time on the E2 impact"};
  app.add_option("--out", out, "JSON file to write");
  app.add_option("--parts", parts, "which parts to run (1 alpha, 2 tolerance, 3 radius, 4 presets)")
      ->delimiter(',')
      ->check(CLI::Range(1, 4));
  CLI11_PARSE(app, argc, argv);
  auto wanted = [&](int part) {
    return std::find(parts.begin(), parts.end(), part) != parts.end();
  };
  nlohmann::json report;

  // 1. alpha, on one bed: the bed of the standard alpha, only the impact's step changes (the
  // bare-plate reference run for lambda keeps the standard step).
  BedCache shared_beds;
  const std::vector<double> alphas = {0.025, 0.05, 0.1, 0.2, 0.4, 0.6, 0.8, 1.0};
  if (wanted(1))
    report["alpha"] =
        Study("1. time-step factor alpha (one bed; reference alpha = 0.025)", "alpha",
              Labels(alphas), 0, false, [&](std::size_t k) {
                return Measure(
                    StudyScene(), [&](World& w) { w.params.dt_s = alphas[k] * w.critical_dt_s; },
                    &shared_beds);
              });

  // 2. settling tolerance.
  const std::vector<double> tolerances = {1e-6, 1e-5, 1e-4, 1e-3};
  if (wanted(2))
    report["settle_tolerance"] =
        Study("2. settling tolerance (own bed each; reference 1e-6)", "tolerance",
              Labels(tolerances), 0, true, [&](std::size_t k) {
                Scene scene = StudyScene();
                scene.bed.settle_tolerance = tolerances[k];
                return Measure(scene);
              });

  // 3. bed diameter.
  const std::vector<double> radii = {0.095, 0.075, 0.055};
  if (wanted(3))
    report["cylinder_radius"] =
        Study("3. cylinder radius (own bed each; reference 0.095 m, the paper's)", "radius [m]",
              Labels(radii), 0, true, [&](std::size_t k) {
                Scene scene = StudyScene();
                scene.cylinder.radius_m = radii[k];
                return Measure(scene);
              });

  // 4. presets, against the reference preset.
  std::vector<std::string> presets;
  for (const AccuracyPreset& p : AccuracyPresets()) presets.emplace_back(p.name);
  if (wanted(4))
    report["presets"] = Study("4. accuracy presets, whole runs (reference: the reference preset)",
                              "preset", presets, presets.size() - 1, true, [&](std::size_t k) {
                                Scene scene = StudyScene();
                                ApplyAccuracy(scene, presets[k]);
                                return Measure(scene);
                              });

  std::ofstream(out) << report.dump(2) << "\n";
  std::printf("\nwrote %s\n", out.c_str());
  return 0;
}
