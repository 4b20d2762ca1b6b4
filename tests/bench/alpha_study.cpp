// What the time-step factor alpha costs in accuracy for single contacts: the restitution of a
// head-on bead pair (against the exact e(v) of the model), the Hertz peak force and contact
// time of an elastic bead pair, and the paper's no-bead impact peak (against its alpha -> 0
// limit). Prints a table and writes JSON (first argument, default alpha_study.json).
#include <cmath>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <numbers>

#include "dembuf/core/damping.h"
#include "dembuf/study/impact/impact.h"
#include "engine/two_body.h"

using namespace dembuf;

namespace {

constexpr double kRadius = 2.25e-3, kDensity = 2650.0;

struct PairRun {
  double restitution;
  double max_force;
  double duration;
  long steps;
};

PairRun HeadOn(const Scene& scene, double alpha, double v) {
  const dem::WorldParams p = test::IsolatedWorld(scene, alpha);
  dem::ParticleState beads;
  beads.Add(dem::Vec3(-kRadius - 1e-9, 0, 1), kRadius, kDensity);
  beads.Add(dem::Vec3(kRadius + 1e-9, 0, 1), kRadius, kDensity);
  beads.velocity[0] = dem::Vec3(0.5 * v, 0, 0);
  beads.velocity[1] = dem::Vec3(-0.5 * v, 0, 0);
  dem::Simulation sim(p, std::move(beads), std::nullopt);
  auto overlap = [](const dem::Simulation& s) {
    return 2 * kRadius - (s.beads().position[0] - s.beads().position[1]).norm();
  };
  auto force = [](const dem::Simulation& s) { return s.beads().force[0].norm(); };
  const test::ContactRecord rec = test::RecordContact(sim, overlap, force, 10'000'000);
  const auto& b = sim.beads();
  return {(b.velocity[1].x() - b.velocity[0].x()) / v, rec.max_force, rec.Duration(),
          static_cast<long>(rec.Duration() / p.dt_s)};
}

}  // namespace

int main(int argc, char** argv) {
  const char* json_path = argc > 1 ? argv[1] : "alpha_study.json";
  Scene damped;
  damped.material.friction_bead_bead = 0.0;
  Scene elastic = damped;
  elastic.material.restitution = 1.0;

  const World world = BuildWorld(damped);
  const double mass = kDensity * 4.0 / 3.0 * std::numbers::pi * std::pow(kRadius, 3);
  const double kn = world.params.sphere_pair.kn_per_sqrt_r * std::sqrt(0.5 * kRadius);
  const double A = world.params.sphere_pair.damping_A_s;
  const test::HertzImpact hertz(kn, 0.5 * mass, 1.0);

  Scene no_beads;
  no_beads.projectile.mass_kg = 0.3;
  no_beads.projectile.speed_m_s = 5.0;
  no_beads.projectile.height_m = 0.30;
  Scene reference_scene = no_beads;
  reference_scene.time.alpha = 0.005;
  const double reference_peak = RunImpact(reference_scene).peak_plate_force_N;

  std::printf("%-6s %-8s %-12s %-12s %-12s %-12s %-12s %-12s\n", "alpha", "steps", "e_err@0.1",
              "e_err@1", "e_err@10", "Fmax_err", "tc_err", "E2_peak_err");
  std::printf("%-6s %-8s %-12s %-12s %-12s %-12s %-12s %-12s\n", "", "/contact", "m/s [%]",
              "m/s [%]", "m/s [%]", "[%]", "[%]", "[%]");
  nlohmann::json rows = nlohmann::json::array();
  for (double alpha : {0.025, 0.05, 0.1, 0.2, 0.3, 0.5, 0.7, 1.0}) {
    nlohmann::json row = {{"alpha", alpha}};
    double e_err[3];
    int k = 0;
    for (double v : {0.1, 1.0, 10.0}) {
      const double exact = dem::RestitutionAtSpeed(A, kn, 0.5 * mass, v);
      e_err[k++] = 100.0 * (HeadOn(damped, alpha, v).restitution / exact - 1.0);
    }
    const PairRun el = HeadOn(elastic, alpha, 1.0);
    Scene s = no_beads;
    s.time.alpha = alpha;
    const double peak = RunImpact(s).peak_plate_force_N;
    row["steps_per_contact_1m_s"] = el.steps;
    row["restitution_error_percent"] = {{"0.1", e_err[0]}, {"1", e_err[1]}, {"10", e_err[2]}};
    row["hertz_peak_force_error_percent"] = 100.0 * (el.max_force / hertz.max_force - 1.0);
    row["hertz_contact_time_error_percent"] = 100.0 * (el.duration / hertz.duration - 1.0);
    row["no_bead_peak_N"] = peak;
    row["no_bead_peak_error_percent"] = 100.0 * (peak / reference_peak - 1.0);
    rows.push_back(row);
    std::printf("%-6.3g %-8ld %-12.3f %-12.3f %-12.3f %-12.3f %-12.3f %-12.4f\n", alpha, el.steps,
                e_err[0], e_err[1], e_err[2], row["hertz_peak_force_error_percent"].get<double>(),
                row["hertz_contact_time_error_percent"].get<double>(),
                row["no_bead_peak_error_percent"].get<double>());
  }
  std::printf("no-bead reference peak (alpha 0.005): %.2f N\n", reference_peak);
  std::ofstream(json_path)
      << nlohmann::json{{"reference_no_bead_peak_N", reference_peak}, {"rows", rows}}.dump(2)
      << "\n";
  std::printf("wrote %s\n", json_path);
}
