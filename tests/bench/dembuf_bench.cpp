// dembuf's benchmark: what a step costs and how that scales. Prints tables and writes JSON.
//
//   dembuf_bench [--out bench.json] [--bed-cache DIR] [--steps N] [--quick] [--sizes-only]
//                [--sweep draft|standard|reference] [--sweep-seeds N] [--sweep-set FIELD=VALUE]...
//                [--sweep-out DIR]
//
// 0. One thread on each core: the fastest runs every one-thread figure (and LAMMPS).
// 1. Impact throughput on a dense settled bed (the E2 scene at H = 2.5 cm, about 8,000 beads,
//    full contact law: friction with history, rotation, damping, plate and cylinder, and the
//    projectile arriving at its impact speed), one thread, in bead-steps per second.
// 2. The same bed and projectile in LAMMPS (GRANULAR package, tests/bench/lammps/in.impact),
//    when `lmp` is installed, alternating with dembuf in this run; the ratio. Then both on a
//    bed LAMMPS settled (tests/bench/lammps/in.settle, from dembuf's loose column, kept in the
//    bed cache) and dembuf imported, with e = 0.8 and e = 1.
// 3. What each optional effect costs: friction (with history and rotation) during the impact;
//    the projectile, on the bed at rest (held above it against none).
// 4. One job on 1 and 2 threads (more where the machine has them).
// 5. Time per step against bead count from 1,000 to 200,000 beads (beds tiled from copies of
//    the settled one, side by side), with the exponent of a power-law fit from 7,000 beads;
//    memory per bead (what the simulation's arrays hold, and the resident growth).
// 6. With --sweep: the wall time of the paper's whole thickness sweep (E2, H = 0 to 8 cm in
//    0.5 cm steps, --sweep-seeds seeds, default one) at that accuracy, beds prepared from
//    nothing in an empty store, one run per core at a time, as `dembuf sweep --jobs N` runs
//    it, and where its time went: inserting and settling the source beds, relaxing the cut
//    beds, the impacts and the stages of their steps. --sweep-set changes a scene field (a
//    lever, e.g. bed.local_settling=false for the sweep as it was before).
#include <malloc.h>
#include <sched.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <numbers>
#include <regex>
#include <sstream>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include "dembuf/study/bed/bed.h"
#include "dembuf/study/files/bed_export.h"
#include "dembuf/study/impact/impact.h"
#include "dembuf/study/scene/presets.h"
#include "dembuf/study/scene/scene_fields.h"
#include "dembuf/study/sweep/local_sweep.h"
#include "dembuf/study/sweep/sweep_plan.h"

using namespace dembuf;
namespace fs = std::filesystem;

namespace {

struct Options {
  fs::path out = "bench.json";
  fs::path bed_cache;
  int steps = 2000;
  bool quick = false;
  bool sweep_only = false;     ///< section 6 alone
  bool sizes_only = false;     ///< sections 0 and 5 alone
  std::string sweep_accuracy;  ///< empty: no sweep
  int sweep_seeds = 1;
  std::vector<std::string> sweep_set;  ///< "field=value" on top of the preset
  fs::path sweep_out;  ///< where the sweep writes its results; empty: a temporary folder
};

double Seconds(std::chrono::steady_clock::duration d) {
  return std::chrono::duration<double>(d).count();
}

// Resident memory of this process now, in bytes.
double ResidentBytes() {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line))
    if (line.rfind("VmRSS:", 0) == 0) return std::stod(line.substr(6)) * 1024.0;
  return 0.0;
}

// The benchmark scene: the paper's E2 impact on a 2.5 cm bed cut from a 3 cm source (so that
// a fresh machine prepares it in minutes; it is cached afterwards).
Scene BenchScene() {
  Scene scene = PresetScene("e2");
  scene.bed.thickness_m = 0.025;
  scene.bed.source_thickness_m = 0.03;
  return scene;
}

// The world with the projectile moved to just above the bed at its impact speed, as the
// impact pipeline leaves it after the analytic free flight.
World ImpactWorld(const Scene& scene, BedCache& cache) {
  World world = BuildWorld(scene, &cache);
  dem::RigidSphere& p = *world.projectile;
  const double drop = p.position.z() - (world.bed_surface_m + p.radius + 1e-4);
  const double v = std::sqrt(scene.projectile.speed_m_s * scene.projectile.speed_m_s +
                             2.0 * scene.gravity_m_s2 * drop);
  p.position.z() -= drop;
  p.velocity.z() = -v;
  return world;
}

// Keeps the calling thread, and the processes it starts, on one core while alive (core < 0:
// no change). This virtual machine's cores are not always equally fast (one ran the same job
// 30% slower than the other for minutes), so every one-thread figure, dembuf's and LAMMPS's,
// is taken on the same core, the fastest.
class PinnedTo {
 public:
  explicit PinnedTo(int core) {
    if (core < 0 || sched_getaffinity(0, sizeof m_saved, &m_saved) != 0) return;
    cpu_set_t one;
    CPU_ZERO(&one);
    CPU_SET(core, &one);
    m_pinned = sched_setaffinity(0, sizeof one, &one) == 0;
  }
  ~PinnedTo() {
    if (m_pinned) sched_setaffinity(0, sizeof m_saved, &m_saved);
  }
  PinnedTo(const PinnedTo&) = delete;
  PinnedTo& operator=(const PinnedTo&) = delete;

 private:
  cpu_set_t m_saved;
  bool m_pinned = false;
};

int g_single_thread_core = -1;  // where one-thread timings run; -1: wherever the OS puts them

struct Timing {
  double seconds = 0.0;
  std::size_t beads = 0;
  int steps = 0;
  dem::StageTimes stages;  ///< where the steps' time went (dembuf's runs)
  double NsPerBeadStep() const { return 1e9 * seconds / (static_cast<double>(beads) * steps); }
};

// Steps a copy of the world `steps` times and times it (neighbor list builds included).
Timing TimeSteps(const World& world, int steps, int threads, bool with_projectile = true) {
  // Several threads start unpinned, so OpenMP's workers may use every core.
  const PinnedTo pin(threads == 1 ? g_single_thread_core : -1);
  dem::WorldParams params = world.params;
  params.threads = threads;
  dem::Simulation sim(params, world.beads, with_projectile ? world.projectile : std::nullopt,
                      world.history);
  sim.RefreshForces();
  const auto start = std::chrono::steady_clock::now();
  for (int k = 0; k < steps; ++k) sim.Step();
  return {Seconds(std::chrono::steady_clock::now() - start), world.beads.size(), steps,
          sim.stage_times()};
}

// The stages of a step as shares of their sum, and as JSON.
void PrintStages(const dem::StageTimes& t) {
  const double sum = t.integration_s + t.neighbours_s + t.forces_s;
  if (sum <= 0) return;
  std::printf(
      "  %-44s integration %.0f%%, neighbours %.0f%% (%lld list builds, %lld sorts), force pass "
      "%.0f%%\n",
      "dembuf's step, by stage:", 100 * t.integration_s / sum, 100 * t.neighbours_s / sum,
      static_cast<long long>(t.list_builds), static_cast<long long>(t.pair_sorts),
      100 * t.forces_s / sum);
}
nlohmann::json StagesJson(const dem::StageTimes& t) {
  return {{"integration_s", t.integration_s},
          {"neighbours_s", t.neighbours_s},
          {"force_pass_s", t.forces_s},
          {"list_builds", t.list_builds},
          {"pair_sorts", t.pair_sorts}};
}

// The serial fraction of a speedup `speedup` on `threads` threads (Karp and Flatt, 1990):
// e = (1/S - 1/p) / (1 - 1/p), the share of the work that did not run in parallel, as Amdahl's
// law would have it. Measured at a few threads it predicts more: S(p) = 1 / (e + (1 - e) / p).
double KarpFlatt(double speedup, int threads) {
  if (threads <= 1 || speedup <= 0.0) return 0.0;
  const double inverse_p = 1.0 / threads;
  return (1.0 / speedup - inverse_p) / (1.0 - inverse_p);
}

// Each stage's serial fraction against its one-thread time, and the whole step's.
nlohmann::json SerialFractions(const Timing& one, const Timing& t, int threads) {
  auto fraction = [&](double one_s, double t_s) {
    return t_s > 0.0 ? KarpFlatt(one_s / t_s, threads) : 0.0;
  };
  return {{"step", fraction(one.seconds, t.seconds)},
          {"integration", fraction(one.stages.integration_s, t.stages.integration_s)},
          {"neighbours", fraction(one.stages.neighbours_s, t.stages.neighbours_s)},
          {"force_pass", fraction(one.stages.forces_s, t.stages.forces_s)}};
}

Timing Best(int repeats, const std::function<Timing()>& run) {
  Timing best;
  for (int r = 0; r < repeats; ++r) {
    const Timing t = run();
    if (r == 0 || t.seconds < best.seconds) best = t;
  }
  return best;
}

// ---- LAMMPS ----------------------------------------------------------------------------------

// Runs a program with its arguments and OMP_NUM_THREADS=1, without a shell in between (no
// word is interpreted); its exit status, or -1 when it could not be started.
int RunProgram(const std::vector<std::string>& args) {
  std::vector<char*> argv;
  for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  std::vector<std::string> env_text = {"OMP_NUM_THREADS=1"};
  for (char** e = environ; *e; ++e)
    if (std::string_view(*e).rfind("OMP_NUM_THREADS=", 0) != 0) env_text.emplace_back(*e);
  std::vector<char*> env;
  for (std::string& e : env_text) env.push_back(e.data());
  env.push_back(nullptr);
  pid_t pid = 0;
  if (posix_spawnp(&pid, argv[0], nullptr, nullptr, argv.data(), env.data()) != 0) return -1;
  int status = 0;
  if (waitpid(pid, &status, 0) != pid) return -1;
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

bool LammpsAvailable() {
  const char* path = std::getenv("PATH");
  std::istringstream dirs(path ? path : "");
  std::string dir;
  while (std::getline(dirs, dir, ':'))
    if (!dir.empty() && access((fs::path(dir) / "lmp").c_str(), X_OK) == 0) return true;
  return false;
}

// LAMMPS's neighbour skin, in smallest diameters: its fastest on the impact of the
// LAMMPS-settled bed (5.67-5.70 s for 2,000 steps, against 5.71-5.82 at 0.15, 5.72-5.84 at
// 0.3, 5.90-6.22 at 0.4 and 5.95-6.23 at 0.1). dembuf's own skin is wider
// (WorldParams::skin_fraction): each code runs with the skin that suits it.
constexpr double kLammpsSkinDiameters = 0.2;

// The variables in.impact and in.settle share: time step, material, contact law, container.
// `friction` is the bead-bead friction (the preparation's for settling).
std::vector<std::string> LammpsVariables(const World& world, const Scene& scene, double friction) {
  const double e_star = 0.75 * world.params.sphere_pair.kn_per_sqrt_r;
  const double m_mean = scene.MeanBeadMass();
  // LAMMPS's viscoelastic damping force is eta0 * a * m_eff * (approach rate), a = sqrt(R d);
  // dembuf's Kuwabara-Kono term is A * 4/3 E* * a * (approach rate): equal for a mean pair.
  const double eta0 = world.params.sphere_pair.damping_A_s * 4.0 / 3.0 * e_star / (0.5 * m_mean);
  auto number = [](double v) {
    std::ostringstream text;
    text.precision(12);
    text << v;
    return text.str();
  };
  return {"-var", "dt",     number(world.params.dt_s),
          "-var", "E",      number(scene.material.youngs_modulus_Pa),
          "-var", "nu",     number(scene.material.poisson_ratio),
          "-var", "eta",    number(eta0),
          "-var", "mu",     number(friction),
          "-var", "muw",    number(scene.material.friction_bead_wall),
          "-var", "radius", number(scene.cylinder.radius_m),
          "-var", "skin",   number(kLammpsSkinDiameters * scene.beads.diameter_min_m),
          "-var", "g",      number(scene.gravity_m_s2)};
}

// Runs LAMMPS on `input` with the variables; false (and the log's last line on stderr) when it
// fails.
bool RunLammpsInput(const fs::path& input, std::vector<std::string> variables,
                    const fs::path& log) {
  std::vector<std::string> args = {"lmp",  "-nocite",    "-screen", "none",
                                   "-log", log.string(), "-in",     input.string()};
  args.insert(args.end(), variables.begin(), variables.end());
  if (RunProgram(args) == 0) return true;
  std::ifstream in(log);
  std::string line, tail;
  while (std::getline(in, line)) tail = line;
  std::fprintf(stderr, "LAMMPS failed: %s\n", tail.c_str());
  return false;
}

// LAMMPS's impact (in.impact) on the data file; returns its loop time, or a negative number
// on failure.
double RunLammps(const fs::path& input, const fs::path& data, const World& world,
                 const Scene& scene, int steps, const fs::path& log) {
  std::vector<std::string> variables =
      LammpsVariables(world, scene, scene.material.friction_bead_bead);
  variables.insert(variables.end(),
                   {"-var", "data", data.string(), "-var", "steps", std::to_string(steps)});
  if (!RunLammpsInput(input, variables, log)) return -1.0;
  std::ifstream in(log);
  const std::regex loop(R"(Loop time of ([0-9.eE+-]+) on 1 procs for (\d+) steps)");
  std::string line;
  std::smatch m;
  while (std::getline(in, line))
    if (std::regex_search(line, m, loop)) return std::stod(m[1]);
  return -1.0;
}

// The loose column of the benchmark's source bed, settled by LAMMPS (in.settle) until the mean
// kinetic energy per bead is below 1e-3 m g d (at most 0.5 s), as a bed.import file (x y z
// radius per line) at `path`; the time it took in `seconds`. Kept at `path` for the next runs.
// The pour and the packing are LAMMPS's; the last rolling beads come to rest in dembuf's
// relaxation of the import (to 1e-5 m g d and the force balance), as LAMMPS would take an hour
// of one core to bring them there at this speed.
bool SettleInLammps(const Scene& scene, const World& world, const fs::path& work,
                    const fs::path& path, double& seconds) {
  const dem::ParticleState loose = InsertSourceBeads(scene);
  std::ofstream(work / "loose.data")
      << ExportBed(loose, scene, BedFormat::kLammps, "dembuf benchmark: the loose column");
  const double d_mean = scene.beads.MeanDiameter();
  const double m_mean = scene.MeanBeadMass();
  constexpr int kCheck = 2000;
  const auto max_checks = static_cast<long>(0.5 / world.params.dt_s / kCheck);
  std::vector<std::string> variables = LammpsVariables(world, scene, scene.bed.prep_friction);
  std::ostringstream ke_rest;
  ke_rest.precision(12);
  ke_rest << 1e-3 * m_mean * scene.gravity_m_s2 * d_mean;
  variables.insert(variables.end(), {"-var", "data", (work / "loose.data").string(), "-var", "out",
                                     (work / "settled.dump").string(), "-var", "check",
                                     std::to_string(kCheck), "-var", "max_checks",
                                     std::to_string(max_checks), "-var", "ke_rest", ke_rest.str()});
  const auto start = std::chrono::steady_clock::now();
  if (!RunLammpsInput(fs::path(DEMBUF_BENCH_DIR) / "lammps" / "in.settle", variables,
                      work / "settle.log"))
    return false;
  seconds = Seconds(std::chrono::steady_clock::now() - start);
  // The dump: ITEM lines, then "id x y z radius" per bead.
  std::ifstream dump(work / "settled.dump");
  std::ostringstream text;
  text << "# dembuf benchmark bed settled by LAMMPS (tests/bench/lammps/in.settle)\n";
  std::string line;
  bool atoms = false;
  std::size_t count = 0;
  while (std::getline(dump, line)) {
    if (line.rfind("ITEM:", 0) == 0) {
      atoms = line.rfind("ITEM: ATOMS", 0) == 0;
      continue;
    }
    if (!atoms) continue;
    std::istringstream fields(line);
    std::string id, x, y, z, r;
    if (!(fields >> id >> x >> y >> z >> r)) return false;
    text << x << " " << y << " " << z << " " << r << "\n";
    ++count;
  }
  if (count != loose.size()) {
    std::fprintf(stderr, "LAMMPS kept %zu of %zu beads\n", count, loose.size());
    return false;
  }
  fs::create_directories(path.parent_path());
  const fs::path partial = path.string() + ".partial";
  std::ofstream(partial) << text.str();
  fs::rename(partial, path);
  return true;
}

// ---- beds of any size ------------------------------------------------------------------------

// `count` beads with the settled bed's structure, every one of them at rest under its own
// weight as in the bed: a square core of the settled bed (inside the cylinder, clear of the
// wall) tiled side by side on the plate, a bead's diameter apart so that no two copies
// overlap, with the core's tangential springs; then the `count` beads nearest the axis, in a
// cylinder just wide enough for them. A bed for timing, not for physics. (Copies stacked on
// top of each other would fall freely: their contacts unload within a few hundred steps, so
// 100,000 beads timed over 50 steps would hold 2.1 contacts per bead and 1,000 timed over
// 2,000 steps about 1.3, and a fit over sizes would compare unlike beds.)
World TiledWorld(const World& base, std::size_t count) {
  const dem::ParticleState& b = base.beads;
  const double r_max = *std::max_element(b.radius.begin(), b.radius.end());
  const double half = (base.params.container.radius_m - 2.0 * r_max) / std::numbers::sqrt2;
  std::vector<std::uint32_t> core;                  // base ids of the core's beads
  std::vector<std::int64_t> core_id(b.size(), -1);  // base id -> index in the core
  for (std::size_t i = 0; i < b.size(); ++i)
    if (std::abs(b.position[i].x()) <= half && std::abs(b.position[i].y()) <= half) {
      core_id[i] = static_cast<std::int64_t>(core.size());
      core.push_back(static_cast<std::uint32_t>(i));
    }
  const double period = 2.0 * half + 2.0 * r_max;
  // Enough tiles around the central one for a disk of `count` beads.
  const double disk =
      period * std::sqrt(static_cast<double>(count) / core.size() / std::numbers::pi);
  const int reach = static_cast<int>(std::ceil(disk / period + 0.5));
  struct Candidate {
    double rho2;
    std::uint32_t bead;  // base id
    dem::Vec3 shift;
    std::uint32_t tile;
  };
  std::vector<Candidate> candidates;
  std::uint32_t tiles = 0;
  for (int tx = -reach; tx <= reach; ++tx)
    for (int ty = -reach; ty <= reach; ++ty, ++tiles) {
      const dem::Vec3 shift(tx * period, ty * period, 0.0);
      for (std::uint32_t i : core) {
        const dem::Vec3 x = b.position[i] + shift;
        candidates.push_back({x.x() * x.x() + x.y() * x.y(), i, shift, tiles});
      }
    }
  if (candidates.size() < count) throw std::runtime_error("too few tiles");
  std::stable_sort(candidates.begin(), candidates.end(),
                   [](const Candidate& x, const Candidate& y) { return x.rho2 < y.rho2; });
  candidates.resize(count);

  World world = base;
  world.projectile.reset();
  world.history.clear();
  dem::ParticleState beads;
  // new id of (tile, core index), for carrying the tangential springs over
  std::vector<std::int64_t> new_id(static_cast<std::size_t>(tiles) * core.size(), -1);
  double rho_max = 0.0;
  for (const Candidate& c : candidates) {
    const std::size_t i = c.bead;
    new_id[c.tile * core.size() + core_id[i]] = static_cast<std::int64_t>(beads.size());
    beads.Add(b.position[i] + c.shift, b.radius[i], 1.0);
    beads.mass.back() = b.mass[i];
    beads.inv_mass.back() = b.inv_mass[i];
    rho_max = std::max(rho_max, std::sqrt(c.rho2));
  }
  for (std::uint32_t tile = 0; tile < tiles; ++tile)
    for (const dem::ContactHistoryEntry& h : base.history) {
      if (core_id[h.bead] < 0 || h.other == dem::kSideWall) continue;
      const std::int64_t bead = new_id[tile * core.size() + core_id[h.bead]];
      std::int64_t other = dem::kPlate;
      if (h.other != dem::kPlate) {
        if (core_id[h.other] < 0) continue;
        other = new_id[tile * core.size() + core_id[h.other]];
      }
      if (bead < 0 || other < 0) continue;
      world.history.push_back(
          {static_cast<std::uint32_t>(bead), static_cast<std::uint32_t>(other), h.shear});
    }
  world.beads = std::move(beads);
  world.params.container.radius_m = rho_max + r_max;
  return world;
}

void PrintRow(const char* what, const Timing& t, double reference_ns = 0.0) {
  std::printf("  %-44s %8zu beads %8.1f ns/bead-step %8.2f M bead-steps/s", what, t.beads,
              t.NsPerBeadStep(), 1e3 / t.NsPerBeadStep());
  if (reference_ns > 0) std::printf("  x%.2f", reference_ns / t.NsPerBeadStep());
  std::printf("\n");
  std::fflush(stdout);
}

nlohmann::json TimingJson(const Timing& t) {
  return {{"beads", t.beads},
          {"steps", t.steps},
          {"seconds", t.seconds},
          {"ns_per_bead_step", t.NsPerBeadStep()},
          {"bead_steps_per_s", 1e9 / t.NsPerBeadStep()}};
}

// Sections 0 to 5: what a step costs, against LAMMPS, with each effect, on threads, and with
// the bead count.
// 2b. Both codes on a bed settled by LAMMPS from the same loose column and imported into
// dembuf, with the paper's damping (e = 0.8) and without (e = 1): the per-core lead measured on
// a bed that favours neither.
void BenchLammpsSettledBed(const Options& opt, const Scene& scene, const World& world,
                           BedCache& cache, int repeats, const fs::path& work,
                           nlohmann::json& report) {
  std::printf("2b. a bed settled by LAMMPS, imported; one thread, %d steps (best of %d)\n",
              opt.steps, repeats);
  const fs::path settled = opt.bed_cache / ("lammps-settled-" + BedSourceHash(scene) + ".txt");
  double lammps_settle_s = -1.0;
  if (!fs::exists(settled)) {
    std::printf("  LAMMPS settles the loose column (once; kept in %s) ...\n", settled.c_str());
    std::fflush(stdout);
    const PinnedTo pin(g_single_thread_core);
    if (!SettleInLammps(scene, world, work, settled, lammps_settle_s)) {
      std::printf("  LAMMPS could not settle the bed (see its log)\n\n");
      report["lammps_settled_bed"] = nullptr;
      return;
    }
  }
  Scene imported = scene;
  imported.bed.import = settled.string();
  imported.bed.import_overlaps = "relax";
  const auto relax_start = std::chrono::steady_clock::now();
  const World damped = ImpactWorld(imported, cache);
  const double relax_s = Seconds(std::chrono::steady_clock::now() - relax_start);
  const std::string lammps_took =
      lammps_settle_s >= 0 ? std::to_string(std::lround(lammps_settle_s)) + " s" : "cached";
  const std::string relax_took = std::to_string(std::lround(relax_s)) + " s";
  std::printf(
      "  %zu beads, H = %.2f cm, C0 = %.3f (settling in LAMMPS: %s; dembuf relaxing the "
      "import: %s)\n",
      damped.beads.size(), 100 * damped.bed.thickness_m, damped.bed.solid_fraction,
      lammps_took.c_str(), relax_took.c_str());
  // Without damping: the same bed and time step, the contact constants of e = 1.
  Scene elastic_scene = imported;
  elastic_scene.material.restitution = 1.0;
  World elastic = damped;
  double min_radius = damped.beads.radius.front();
  for (double r : damped.beads.radius) min_radius = std::min(min_radius, r);
  elastic.params = MakeContactSetup(elastic_scene, min_radius).params;
  elastic.params.dt_s = damped.params.dt_s;

  nlohmann::json rows = nlohmann::json::array();
  const fs::path lammps_input = fs::path(DEMBUF_BENCH_DIR) / "lammps" / "in.impact";
  struct Case {
    double e;
    const World* w;
    const Scene* sc;
  };
  for (const Case& c : {Case{0.8, &damped, &imported}, Case{1.0, &elastic, &elastic_scene}}) {
    const double e = c.e;
    const World* w = c.w;
    const Scene* sc = c.sc;
    std::ofstream(work / "imported.data")
        << ExportBed(w->beads, *sc, BedFormat::kLammps, "dembuf benchmark: bed settled by LAMMPS",
                     w->projectile);
    Timing ours, theirs;
    for (int r = 0; r < repeats; ++r) {
      const Timing t = TimeSteps(*w, opt.steps, 1);
      if (r == 0 || t.seconds < ours.seconds) ours = t;
      const PinnedTo pin(g_single_thread_core);
      const double s =
          RunLammps(lammps_input, work / "imported.data", *w, *sc, opt.steps, work / "log.lammps");
      if (s > 0 && (theirs.seconds == 0 || s < theirs.seconds))
        theirs = Timing{s, w->beads.size() + 1, opt.steps, {}};
    }
    char what[64];
    std::snprintf(what, sizeof what, "dembuf, e = %.1f", e);
    PrintRow(what, ours);
    std::snprintf(what, sizeof what, "LAMMPS, e = %.1f", e);
    if (theirs.seconds <= 0) {
      std::printf("  %s: run failed (see its log)\n", what);
      continue;
    }
    PrintRow(what, theirs);
    const double ratio = theirs.NsPerBeadStep() / ours.NsPerBeadStep();
    std::printf("  dembuf / LAMMPS throughput, e = %.1f: %.2f\n", e, ratio);
    rows.push_back(nlohmann::json{{"restitution", e},
                                  {"dembuf", TimingJson(ours)},
                                  {"lammps", TimingJson(theirs)},
                                  {"dembuf_over_lammps", ratio}});
  }
  std::printf("\n");
  report["lammps_settled_bed"] = {{"beads", damped.beads.size()},
                                  {"thickness_m", damped.bed.thickness_m},
                                  {"C0", damped.bed.solid_fraction},
                                  {"lammps_settle_s", lammps_settle_s},
                                  {"runs", rows}};
}

// 5. Time per step against bead count, and memory per bead.
void BenchSizes(const Options& opt, const World& world, int repeats, nlohmann::json& report) {
  std::printf("5. time per step against bead count (one thread)\n");
  nlohmann::json sizes = nlohmann::json::array();
  std::vector<std::pair<double, double>> points;
  const std::vector<std::size_t> counts =
      opt.quick ? std::vector<std::size_t>{1000, 7000, 30000}
                : std::vector<std::size_t>{1000, 7000, 20000, 60000, 200000};
  // The fit covers 7,000 beads (a thin bed of the paper) and up; 1,000 fit in the caches.
  constexpr std::size_t kFitFrom = 7000;
  // Every size is timed over the same first 200 steps, whose contacts per bead are alike at
  // every size (the tiles' seams and the new wall let the beads near them unload, at the same
  // pace everywhere), and repeated until it has taken about 4e6 bead-steps: best of them.
  constexpr int kSizeSteps = 200;
  double bytes_per_bead = 0.0, resident_per_bead = 0.0;
  for (std::size_t n : counts) {
    const World w = TiledWorld(world, n);
    const int tries = std::max<int>(repeats, static_cast<int>(4'000'000 / (n * kSizeSteps)));
    const Timing t = Best(tries, [&] { return TimeSteps(w, kSizeSteps, 1); });
    const double us_per_step = 1e6 * t.seconds / kSizeSteps;
    std::printf("  %8zu beads  %10.1f us/step  %8.1f ns/bead-step\n", n, us_per_step,
                t.NsPerBeadStep());
    std::fflush(stdout);
    if (n >= kFitFrom) points.push_back({std::log(static_cast<double>(n)), std::log(us_per_step)});
    sizes.push_back({{"beads", n}, {"us_per_step", us_per_step}, {"timing", TimingJson(t)}});
    if (n == counts.back()) {
      // Memory: what a simulation of this size holds, with its springs, after a few steps;
      // and the process's resident growth while it lives (the allocator's share included).
      // Freed memory goes back to the system before each reading, or the growth would reuse
      // what the timings freed and count what the construction needed only for a while.
      malloc_trim(0);
      const double rss_before = ResidentBytes();
      dem::Simulation sim(w.params, w.beads, std::nullopt, w.history);
      for (int k = 0; k < 10; ++k) sim.Step();
      bytes_per_bead = static_cast<double>(sim.MemoryBytes()) / static_cast<double>(n);
      malloc_trim(0);
      resident_per_bead = (ResidentBytes() - rss_before) / static_cast<double>(n);
    }
  }
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  for (const auto& [x, y] : points) {
    sx += x;
    sy += y;
    sxx += x * x;
    sxy += x * y;
  }
  const double np = static_cast<double>(points.size());
  const double exponent = (np * sxy - sx * sy) / (np * sxx - sx * sx);
  std::printf("  fit from %zu to %zu beads: time per step ~ beads^%.3f\n", kFitFrom, counts.back(),
              exponent);
  std::printf(
      "  memory: %.0f bytes per bead held by the simulation (%.0f resident growth; "
      "%zu-bead simulation)\n\n",
      bytes_per_bead, resident_per_bead, counts.back());
  report["sizes"] = sizes;
  report["size_exponent"] = exponent;
  report["bytes_per_bead"] = bytes_per_bead;
  report["resident_bytes_per_bead"] = resident_per_bead;
}

void BenchSteps(const Options& opt, nlohmann::json& report) {
  const int repeats = opt.quick ? 1 : 3;
  std::printf("preparing (or loading) the benchmark bed: E2 scene, H = 2.5 cm ...\n");
  std::fflush(stdout);
  const Scene scene = BenchScene();
  BedCache cache(opt.bed_cache);
  const World world = ImpactWorld(scene, cache);
  std::printf("bed: %zu beads, H = %.2f cm, C0 = %.3f, dt = %.4g us\n\n", world.beads.size(),
              100 * world.bed.thickness_m, world.bed.solid_fraction, world.params.dt_s * 1e6);
  report["bed"] = {{"beads", world.beads.size()},
                   {"thickness_m", world.bed.thickness_m},
                   {"C0", world.bed.solid_fraction},
                   {"dt_s", world.params.dt_s}};

  // 0. The fastest core, for every one-thread figure below.
  std::printf("0. one thread on each core (300 impact steps, best of 2)\n");
  cpu_set_t allowed;
  nlohmann::json cores = nlohmann::json::array();
  double fastest_ns = 0.0;
  if (sched_getaffinity(0, sizeof allowed, &allowed) == 0)
    for (int core = 0; core < CPU_SETSIZE && cores.size() < 64; ++core) {
      if (!CPU_ISSET(core, &allowed)) continue;
      const PinnedTo pin(core);
      const Timing t = Best(2, [&] { return TimeSteps(world, 300, 1); });
      std::printf("  core %d: %.1f ns/bead-step\n", core, t.NsPerBeadStep());
      cores.push_back({{"core", core}, {"ns_per_bead_step", t.NsPerBeadStep()}});
      if (g_single_thread_core < 0 || t.NsPerBeadStep() < fastest_ns) {
        g_single_thread_core = core;
        fastest_ns = t.NsPerBeadStep();
      }
    }
  std::printf("  one-thread figures below run on core %d, LAMMPS's too\n\n", g_single_thread_core);
  report["cores"] = cores;
  report["single_thread_core"] = g_single_thread_core;
  if (opt.sizes_only) return BenchSizes(opt, world, repeats, report);

  // 1 and 2: dembuf and LAMMPS, alternating.
  std::printf("1-2. impact on the settled bed, one thread, %d steps (best of %d)\n", opt.steps,
              repeats);
  const bool lammps = LammpsAvailable();
  const fs::path work = fs::temp_directory_path() / ("dembuf-bench-" + std::to_string(getpid()));
  fs::create_directories(work);
  const fs::path lammps_input = fs::path(DEMBUF_BENCH_DIR) / "lammps" / "in.impact";
  if (lammps) {
    std::ofstream(work / "bed.data") << ExportBed(world.beads, scene, BedFormat::kLammps,
                                                  "dembuf benchmark bed", world.projectile);
  }
  Timing ours, theirs;
  for (int r = 0; r < repeats; ++r) {
    const Timing t = TimeSteps(world, opt.steps, 1);
    if (r == 0 || t.seconds < ours.seconds) ours = t;
    if (lammps) {
      const PinnedTo pin(g_single_thread_core);  // LAMMPS inherits the core
      const double s =
          RunLammps(lammps_input, work / "bed.data", world, scene, opt.steps, work / "log.lammps");
      if (s > 0 && (theirs.seconds == 0 || s < theirs.seconds))
        theirs = {s, world.beads.size() + 1, opt.steps, {}};
    }
  }
  PrintRow("dembuf (full contact law, projectile)", ours);
  PrintStages(ours.stages);
  report["impact_one_thread"] = TimingJson(ours);
  report["impact_one_thread"]["stages"] = StagesJson(ours.stages);
  if (theirs.seconds > 0) {
    PrintRow("LAMMPS GRANULAR, same bed and steps", theirs);
    const double ratio = theirs.NsPerBeadStep() / ours.NsPerBeadStep();
    std::printf("  dembuf / LAMMPS throughput: %.2f\n\n", ratio);
    report["lammps_one_thread"] = TimingJson(theirs);
    report["dembuf_over_lammps"] = ratio;
  } else {
    std::printf("  LAMMPS: %s\n\n", lammps ? "run failed (see its log)" : "not installed (lmp)");
    report["lammps_one_thread"] = nullptr;
  }
  if (lammps) BenchLammpsSettledBed(opt, scene, world, cache, repeats, work, report);
  fs::remove_all(work);

  // 3. Effects.
  std::printf("3. what each effect costs (one thread, best of %d)\n", repeats);
  World frictionless = world;
  frictionless.params.sphere_pair.friction = 0.0;
  frictionless.params.sphere_wall.friction = 0.0;
  frictionless.history.clear();
  const Timing no_friction = Best(repeats, [&] { return TimeSteps(frictionless, opt.steps, 1); });
  // The projectile's own cost, on the bed at rest: held 1 cm above the surface (it falls, but
  // touches nothing within the timing) against no projectile at all. An impact is not
  // comparable with a bed at rest: the bed's state, not the projectile, sets the cost there.
  World waiting = world;
  waiting.projectile->position.z() += 0.01;
  waiting.projectile->velocity.setZero();
  const Timing projectile_above = Best(repeats, [&] { return TimeSteps(waiting, opt.steps, 1); });
  const Timing no_projectile = Best(repeats, [&] { return TimeSteps(world, opt.steps, 1, false); });
  // Two species on the same bed and step: every other bead of a glass 20% stiffer, so that
  // every contact gathers its kind of pair's constants (SpeciesPairs) and the motion is the
  // impact's. (Steel shot's own cost is mostly its shorter step: docs/performance.md.)
  Scene two_species_scene = scene;
  two_species_scene.layers[0].fraction2 = 0.5;
  two_species_scene.species[0] = {.name = "stiffer glass",
                                  .density_kg_m3 = scene.material.density_kg_m3,
                                  .youngs_modulus_Pa = 1.2 * scene.material.youngs_modulus_Pa,
                                  .poisson_ratio = scene.material.poisson_ratio};
  World two_species = world;
  two_species.params = MakeContactSetup(two_species_scene, 0.5 * scene.beads.diameter_min_m).params;
  two_species.params.dt_s = world.params.dt_s;
  for (std::size_t i = 0; i < two_species.beads.size(); ++i)
    two_species.beads.species[i] = static_cast<dem::Species>(i % 2);
  const Timing species = Best(repeats, [&] { return TimeSteps(two_species, opt.steps, 1); });
  PrintRow("everything (impact)", ours);
  PrintRow("two species, mixed (constants by pair)", species, ours.NsPerBeadStep());
  PrintRow("without friction (no history, no rotation)", no_friction, ours.NsPerBeadStep());
  PrintRow("bed at rest, projectile above it", projectile_above);
  PrintRow("bed at rest, no projectile", no_projectile, projectile_above.NsPerBeadStep());
  std::printf("\n");
  report["effects"] = {{"full", TimingJson(ours)},
                       {"two_species", TimingJson(species)},
                       {"no_friction", TimingJson(no_friction)},
                       {"rest_projectile_above", TimingJson(projectile_above)},
                       {"rest_no_projectile", TimingJson(no_projectile)}};

  // 4. Threads: a bed of about 30,000 beads at rest, and the impact of section 1.
  const int max_threads = std::max(2u, std::thread::hardware_concurrency());
  const World big = TiledWorld(world, 30000);
  auto thread_series = [&](const World& w, int steps, bool projectile) {
    nlohmann::json scaling = nlohmann::json::array();
    Timing one;
    for (int threads = 1; threads <= max_threads; threads *= 2) {
      const Timing t = Best(repeats, [&] { return TimeSteps(w, steps, threads, projectile); });
      if (threads == 1) one = t;
      char label[64];
      std::snprintf(label, sizeof label, "%d thread%s", threads, threads > 1 ? "s" : "");
      PrintRow(label, t, one.NsPerBeadStep());
      // Where the threads' time goes: a stage that runs on one thread (or scales badly) shows
      // here as a share growing with the thread count.
      if (projectile) PrintStages(t.stages);
      nlohmann::json serial = nullptr;
      if (projectile && threads > 1) {
        serial = SerialFractions(one, t, threads);
        std::printf("  %-44s step %.3f: integration %.3f, neighbours %.3f, force pass %.3f\n",
                    "serial fraction (Karp-Flatt), by stage:", serial["step"].get<double>(),
                    serial["integration"].get<double>(), serial["neighbours"].get<double>(),
                    serial["force_pass"].get<double>());
      }
      scaling.push_back({{"threads", threads},
                         {"timing", TimingJson(t)},
                         {"speedup", one.seconds / t.seconds},
                         {"serial_fraction", serial},
                         {"stages", StagesJson(t.stages)}});
    }
    return scaling;
  };
  std::printf("4. one job on more threads: tiled bed at rest (%zu beads, %d steps, best of %d)\n",
              big.beads.size(), opt.steps / 4, repeats);
  report["threads"] = thread_series(big, opt.steps / 4, false);
  std::printf("   the impact of section 1 (%zu beads, %d steps, best of %d)\n", world.beads.size(),
              opt.steps, repeats);
  report["threads_impact"] = thread_series(world, opt.steps, true);
  std::printf("\n");

  BenchSizes(opt, world, repeats, report);
}

// Section 6: the whole E2 sweep from an empty bed store, and where its time went.
void BenchSweep(const Options& opt, nlohmann::json& report) {
  const int jobs = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  Scene e2 = PresetScene("e2");
  ApplyAccuracy(e2, opt.sweep_accuracy);
  for (const std::string& assignment : opt.sweep_set) ApplyOverride(e2, assignment);
  std::string changes;
  for (const std::string& assignment : opt.sweep_set) changes += ", " + assignment;
  std::printf(
      "6. the E2 thickness sweep, H = 0 to 8 cm in 0.5 cm steps, %d seed%s, accuracy %s%s, "
      "beds prepared from nothing, %d runs at a time\n",
      opt.sweep_seeds, opt.sweep_seeds > 1 ? "s" : "", opt.sweep_accuracy.c_str(), changes.c_str(),
      jobs);
  std::fflush(stdout);
  SweepOptions sweep;
  sweep.axes = {ParseSweepAxis("bed.thickness_m=0:0.08:0.005")};
  sweep.seeds = opt.sweep_seeds;
  sweep.jobs = jobs;
  const fs::path scratch =
      fs::temp_directory_path() / ("dembuf-bench-sweep-" + std::to_string(getpid()));
  sweep.out_dir = opt.sweep_out.empty() ? scratch / "out" : opt.sweep_out;
  BedCache empty_store(scratch / "beds");
  // Where the time goes: the beds this sweep prepared, and its runs' impacts.
  std::mutex account_mutex;
  std::map<std::string, std::pair<int, double>> bed_stages;  // stage: count, seconds
  double insert_s = 0.0, impact_s = 0.0;
  std::int64_t source_steps = 0, impact_steps = 0;
  dem::StageTimes step_stages;
  int impacts = 0;
  sweep.on_bed_prepared = [&](const PreparedBed& bed) {
    std::lock_guard lock(account_mutex);
    auto& [count, seconds] = bed_stages[bed.stage];
    ++count;
    seconds += bed.wall_time_s - bed.insert_time_s;
    insert_s += bed.insert_time_s;
    if (bed.stage == "source") source_steps += bed.settle_steps;
  };
  sweep.on_run_done = [&](const SweepRun&, const ImpactSummary& summary) {
    std::lock_guard lock(account_mutex);
    ++impacts;
    impact_s += summary.wall_time_s;
    impact_steps += summary.steps;
    step_stages.integration_s += summary.stage_times.integration_s;
    step_stages.neighbours_s += summary.stage_times.neighbours_s;
    step_stages.forces_s += summary.stage_times.forces_s;
    step_stages.list_builds += summary.stage_times.list_builds;
    step_stages.pair_sorts += summary.stage_times.pair_sorts;
  };
  const auto start = std::chrono::steady_clock::now();
  const int failed = RunSweep(e2, sweep, empty_store);
  const double seconds = Seconds(std::chrono::steady_clock::now() - start);
  fs::remove_all(scratch);
  std::printf("  E2 sweep (%s, %d seed%s): %.0f s wall, %d failed runs\n",
              opt.sweep_accuracy.c_str(), opt.sweep_seeds, opt.sweep_seeds > 1 ? "s" : "", seconds,
              failed);
  auto stage = [&](const char* name) {
    return bed_stages.count(name) ? bed_stages[name] : std::pair<int, double>{0, 0.0};
  };
  const double stepped =
      step_stages.integration_s + step_stages.neighbours_s + step_stages.forces_s;
  std::printf(
      "  where it went, in computing seconds (a stage on 2 threads counts its wall time):\n");
  std::printf("    %-44s %8.0f s\n", "bed generation (inserting the source beads)", insert_s);
  std::printf("    %-44s %8.0f s  (%d beds, %lld steps)\n", "settling the source beds",
              stage("source").second, stage("source").first, static_cast<long long>(source_steps));
  std::printf("    %-44s %8.0f s  (%d beds)\n", "cutting and relaxing the cut beds",
              stage("cut").second, stage("cut").first);
  if (stage("friction").first > 0)
    std::printf("    %-44s %8.0f s  (%d beds)\n", "changing the friction", stage("friction").second,
                stage("friction").first);
  std::printf("    %-44s %8s\n", "free fall", "computed, not stepped");
  std::printf("    %-44s %8.0f s  (%d runs, %lld steps)\n", "impacts", impact_s, impacts,
              static_cast<long long>(impact_steps));
  if (stepped > 0)
    std::printf(
        "      of their steps: integration %.0f%%, neighbours %.0f%% (%lld list builds, %lld "
        "sorts), force pass %.0f%%\n",
        100 * step_stages.integration_s / stepped, 100 * step_stages.neighbours_s / stepped,
        static_cast<long long>(step_stages.list_builds),
        static_cast<long long>(step_stages.pair_sorts), 100 * step_stages.forces_s / stepped);
  std::printf("\n");
  report["e2_sweep"] = {
      {"accuracy", opt.sweep_accuracy},
      {"set", opt.sweep_set},
      {"seeds", opt.sweep_seeds},
      {"runs", ExpandSweep(e2, WithSeedAxis(sweep.axes, opt.sweep_seeds, e2.bed.seed)).size()},
      {"jobs", jobs},
      {"failed", failed},
      {"seconds", seconds},
      {"phases_s",
       {{"insert", insert_s},
        {"source_settling", stage("source").second},
        {"cut_relaxation", stage("cut").second},
        {"friction", stage("friction").second},
        {"impacts", impact_s},
        {"impact_integration", step_stages.integration_s},
        {"impact_neighbours", step_stages.neighbours_s},
        {"impact_force_pass", step_stages.forces_s}}},
      {"beds_prepared",
       {{"source", stage("source").first},
        {"cut", stage("cut").first},
        {"friction", stage("friction").first}}}};
}

}  // namespace

int main(int argc, char** argv) {
  Options opt;
  CLI::App app{"dembuf's speed benchmark: what a step costs, against LAMMPS, and how it scales"};
  app.add_option("--out", opt.out, "JSON file to write")->capture_default_str();
  app.add_option("--bed-cache", opt.bed_cache, "prepared beds (default ~/.cache/dembuf/beds)");
  app.add_option("--steps", opt.steps, "impact steps per timing")
      ->capture_default_str()
      ->check(CLI::Range(10, 1000000));
  app.add_flag("--quick", opt.quick, "one repeat per timing and fewer bed sizes");
  std::vector<std::string> accuracies;
  for (const AccuracyPreset& p : AccuracyPresets()) accuracies.emplace_back(p.name);
  app.add_option("--sweep", opt.sweep_accuracy,
                 "also time the whole E2 thickness sweep at this accuracy, beds included")
      ->check(CLI::IsMember(accuracies));
  app.add_option("--sweep-seeds", opt.sweep_seeds, "bed seeds of the sweep (1, 2, ...)")
      ->check(CLI::Range(1, 100))
      ->needs("--sweep");
  app.add_option("--sweep-set", opt.sweep_set,
                 "a scene field of the sweep, FIELD=VALUE (as dembuf run --set)")
      ->needs("--sweep");
  app.add_flag("--sizes-only", opt.sizes_only,
               "of the steps, time only bead counts and memory (sections 0 and 5)");
  app.add_flag("--sweep-only", opt.sweep_only, "time the sweep alone, not the steps")
      ->needs("--sweep");
  app.add_option("--sweep-out", opt.sweep_out,
                 "keep the sweep's results (sweep.csv, runs) in this folder; it must not exist")
      ->check(CLI::NonexistentPath);
  CLI11_PARSE(app, argc, argv);
  if (opt.bed_cache.empty()) {
    const char* home = std::getenv("HOME");
    opt.bed_cache = fs::path(home ? home : ".") / ".cache" / "dembuf" / "beds";
  }
  nlohmann::json report = {{"machine_cores", std::thread::hardware_concurrency()},
                           {"steps", opt.steps}};

  if (!opt.sweep_only) BenchSteps(opt, report);
  if (!opt.sweep_accuracy.empty()) BenchSweep(opt, report);

  std::ofstream(opt.out) << report.dump(2) << "\n";
  std::printf("wrote %s\n", opt.out.c_str());
  return 0;
}
