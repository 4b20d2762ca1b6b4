#include "local/cost_check.h"

#include <sys/statvfs.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <map>
#include <sstream>

#include "dembuf/study/sweep/schedule.h"

namespace dembuf::cli {

namespace fs = std::filesystem;

namespace {

// A run predicted to compute longer than this asks for --yes.
constexpr double kLongRun_s = 86400;

// Free bytes on the file system that will hold `dir` (its nearest existing ancestor).
double FreeBytes(fs::path dir) {
  std::error_code error;
  dir = fs::absolute(dir, error);
  while (!dir.empty() && !fs::exists(dir, error) && dir != dir.parent_path())
    dir = dir.parent_path();
  struct statvfs info {};
  if (statvfs(dir.c_str(), &info) != 0) return 0.0;  // unknown: no limit
  return static_cast<double>(info.f_bavail) * static_cast<double>(info.f_frsize);
}

double PhysicalMemory() {
  const long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGE_SIZE);
  return pages > 0 && page > 0 ? static_cast<double>(pages) * static_cast<double>(page) : 0.0;
}

// What a set of runs costs together, each bed once (the runs share it) and only if it is not
// in the cache yet: predicted seconds of one core, and bounds.
struct Totals {
  double seconds = 0.0, steps = 0.0, bead_steps = 0.0, samples = 0.0, files = 0.0, memory = 0.0;
  std::map<std::string, int> to_prepare, ready;  // beds by stage
};

Totals Total(const std::vector<ResourceEstimate>& costs, BedCache& beds) {
  Totals t;
  std::vector<std::string> counted;
  for (const ResourceEstimate& cost : costs) {
    std::vector<std::string> skip = counted;
    for (const StageEstimate& s : cost.stages) {
      if (std::find(counted.begin(), counted.end(), s.hash) != counted.end()) continue;
      counted.push_back(s.hash);
      if (beds.Contains(s.hash)) {
        ++t.ready[s.stage];
        skip.push_back(s.hash);
      } else {
        ++t.to_prepare[s.stage];
      }
    }
    t.seconds += cost.PredictedSeconds(1, skip);
    t.steps += cost.StepsMax(skip);
    t.bead_steps += cost.BeadStepsMax(skip);
    t.samples += cost.samples_max;
    t.files += cost.output_bytes_max;
    t.memory = std::max(t.memory, cost.memory_bytes_max);
  }
  return t;
}

}  // namespace

std::vector<std::string> CachedBeds(const ResourceEstimate& estimate, BedCache& beds) {
  std::vector<std::string> cached;
  for (const StageEstimate& s : estimate.stages)
    if (beds.Contains(s.hash)) cached.push_back(s.hash);
  return cached;
}

void CheckLocalCost(const std::vector<Scene>& scenes, const std::vector<ResourceEstimate>& costs,
                    const fs::path& out_dir, int runs_at_once, BedCache& beds, bool yes) {
  // What no run can do: number more beads than a simulation holds.
  ResourceLimits hard;
  hard.beads = kMaxBeads;
  for (std::size_t k = 0; k < costs.size(); ++k)
    CheckResources(costs[k], hard, scenes[k], "a simulation's");
  if (yes) return;
  const std::string ask = " (pass --yes to run it anyway)";
  // Memory: runs at once share the machine; files: all of them share the disk.
  ResourceLimits limits;
  limits.memory_bytes = 0.5 * PhysicalMemory() / std::max(1, runs_at_once);
  for (std::size_t k = 0; k < costs.size(); ++k) {
    try {
      CheckResources(costs[k], limits, scenes[k], "this machine's");
    } catch (const ResourceError& e) {
      throw ResourceError(e.field(), std::string(e.what()).substr(e.field().size() + 2) +
                                         " (half its memory" +
                                         (runs_at_once > 1 ? ", shared by the runs at once" : "") +
                                         "; pass --yes to run it anyway)");
    }
  }
  const Totals total = Total(costs, beds);
  const double files = total.files, seconds = total.seconds;
  const double free = FreeBytes(out_dir);
  if (free > 0.0 && files > 0.9 * free)
    throw ResourceError("time.output_interval_s",
                        "the output would take up to " + HumanBytes(files) + ", and " +
                            out_dir.string() + " has " + HumanBytes(free) + " free" + ask);
  if (seconds > kLongRun_s)
    throw ResourceError(costs.size() == 1 ? "time.alpha" : "--vary",
                        "the computing would take about " + HumanSeconds(seconds) +
                            " of one core (dembuf run --dry-run shows the estimate)" + ask);
}

std::string DescribeRun(const ResourceEstimate& estimate, BedCache& beds, int threads) {
  return DescribeEstimate(estimate, CachedBeds(estimate, beds), threads);
}

std::string DescribeSweep(const std::vector<ResourceEstimate>& costs, BedCache& beds, int jobs,
                          int cores) {
  const Totals t = Total(costs, beds);
  std::ostringstream out;
  out << costs.size() << " runs\n";
  for (const auto& [stage, n] : t.to_prepare)
    out << "beds to prepare: " << n << " " << stage << "\n";
  for (const auto& [stage, n] : t.ready) out << "beds in the cache: " << n << " " << stage << "\n";
  char line[256];
  std::snprintf(line, sizeof line,
                "at most %.3g time steps, %.3g bead-steps, %.3g force samples, %s of files\n",
                t.steps, t.bead_steps, t.samples, HumanBytes(t.files).c_str());
  out << line;
  // No more runs go at once than there are cores (RunQueue).
  const int at_once = std::max(1, std::min(jobs, cores));
  out << "memory: at most " << HumanBytes(t.memory) << " per run, " << at_once << " at once\n";
  return out.str();
}

std::string DescribeSweepPlan(const std::vector<SweepRun>& runs, BedCache& beds, int jobs,
                              int cores, int rounds) {
  const std::vector<RunLoad> loads = LoadsOf(runs, &beds);
  const SchedulePlan plan = PlanSchedule(loads, StartOrder(loads), cores, jobs);
  std::ostringstream out;
  char line[512];
  out << "plan: " << runs.size() << " runs, " << std::max(1, std::min(jobs, cores))
      << " at once (--jobs " << jobs << ", " << cores << " usable CPUs)\n";
  // Each source bed: cached, or prepared by the run that starts first with it.
  std::vector<std::string> listed;
  for (const PlannedRun& p : plan.runs) {
    const std::string& hash = runs[p.run].beds.source_hash;
    if (hash.empty() || std::find(listed.begin(), listed.end(), hash) != listed.end()) continue;
    listed.push_back(hash);
    const auto of_bed = std::count_if(
        runs.begin(), runs.end(), [&](const SweepRun& r) { return r.beds.source_hash == hash; });
    if (!p.prepares_source)
      std::snprintf(line, sizeof line, "  source bed %s: in the cache; %td %s\n", hash.c_str(),
                    of_bed, of_bed == 1 ? "run" : "runs");
    else
      std::snprintf(line, sizeof line,
                    "  source bed %s: prepared by %s on %d %s, while the other runs of it wait; "
                    "%td %s\n",
                    hash.c_str(), runs[p.run].name.c_str(), p.threads_at_start,
                    p.threads_at_start == 1 ? "thread" : "threads", of_bed,
                    of_bed == 1 ? "run" : "runs");
    out << line;
  }
  const auto without_source = std::count_if(
      runs.begin(), runs.end(), [](const SweepRun& r) { return r.beds.source_hash.empty(); });
  if (without_source > 0)
    out << "  no source bed (bare plate or an imported bed): " << without_source
        << (without_source == 1 ? " run, beside the others\n" : " runs, beside the others\n");
  // When each run starts, heaviest first within a source bed.
  out << "  start order (predicted start, threads):";
  for (std::size_t k = 0; k < plan.runs.size(); ++k) {
    if (k == 8 && plan.runs.size() > 10) {
      out << " ... (" << plan.runs.size() - 9 << " more)";
      k = plan.runs.size() - 1;
    }
    std::snprintf(line, sizeof line, "%s %s at %s (%d)", k == 0 ? "" : ",",
                  runs[plan.runs[k].run].name.c_str(), HumanSeconds(plan.runs[k].start_s).c_str(),
                  plan.runs[k].threads_at_start);
    out << line;
  }
  out << "\n";
  const double busy = plan.wall_s > 0 ? plan.one_thread_s / (plan.wall_s * plan.cores) : 0.0;
  out << "predicted wall time: about " << HumanSeconds(rounds * plan.wall_s);
  if (rounds > 1)
    out << " (" << rounds << " steps of the search, " << HumanSeconds(plan.wall_s) << " each)";
  std::snprintf(line, sizeof line,
                " on %d usable %s (%s of one thread's work, %.0f%% of the cores; measured costs "
                "per bead-step, typical settling, a serial fraction of %.2f a step)\n",
                cores, cores == 1 ? "CPU" : "CPUs",
                HumanSeconds(rounds * plan.one_thread_s).c_str(), 100 * busy, kStepSerialFraction);
  out << line;
  return out.str();
}

}  // namespace dembuf::cli
