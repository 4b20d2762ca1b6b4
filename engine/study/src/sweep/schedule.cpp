#include "dembuf/study/sweep/schedule.h"

#include <algorithm>
#include <limits>
#include <map>
#include <numeric>

#include "dembuf/core/threads.h"

namespace dembuf {

namespace {

// Gives the runs `which` of `running` a core at a time in turn, each up to what its bed can
// feed, while `free` cores are left.
void GiveInTurn(const std::vector<CoreClaim>& running, const std::vector<std::size_t>& which,
                std::vector<int>& threads, int& free) {
  for (bool gave = true; free > 0 && gave;) {
    gave = false;
    for (const std::size_t k : which)
      if (free > 0 && threads[k] < running[k].threads_max) {
        ++threads[k];
        --free;
        gave = true;
      }
  }
}

}  // namespace

std::vector<int> ShareCores(int cores, const std::vector<CoreClaim>& running) {
  std::vector<int> threads(running.size(), 1);
  int free = std::max(cores, 1) - static_cast<int>(running.size());
  // The runs others wait for share the free cores in proportion to how many wait for each, a
  // core at a time to the run with the most waiting per thread it has (the highest-averages
  // rule of seat apportionment), each up to what its bed can feed: one run more waiting moves
  // a share by a core, and near-even shares of like work end it soonest, as each thread added
  // gains less (Amdahl's law). A tie goes to the more waited-for, then to the earlier run.
  for (; free > 0; --free) {
    std::size_t best = running.size();
    for (std::size_t k = 0; k < running.size(); ++k) {
      if (running[k].waiting <= 0 || threads[k] >= running[k].threads_max) continue;
      if (best == running.size()) {
        best = k;
        continue;
      }
      // waiting[k] / threads[k] against waiting[best] / threads[best], in integers.
      const long mine = static_cast<long>(running[k].waiting) * threads[best];
      const long theirs = static_cast<long>(running[best].waiting) * threads[k];
      if (mine > theirs || (mine == theirs && running[k].waiting > running[best].waiting)) best = k;
    }
    if (best == running.size()) break;
    ++threads[best];
  }
  // The others in turn.
  std::vector<std::size_t> all(running.size());
  std::iota(all.begin(), all.end(), std::size_t{0});
  GiveInTurn(running, all, threads, free);
  return threads;
}

RunLoad LoadOf(const ResourceEstimate& estimate, const std::string& source_hash,
               const std::vector<std::string>& cached) {
  RunLoad load;
  load.known = true;
  load.source_hash = source_hash;
  load.beads = estimate.impact_beads;
  load.rest_s = estimate.ImpactSeconds(1);
  for (const StageEstimate& stage : estimate.stages) {
    const bool ready = std::find(cached.begin(), cached.end(), stage.hash) != cached.end();
    if (stage.stage == "source") {
      load.source_beads = stage.beads;
      load.source_s = ready ? 0.0 : estimate.StageSeconds(stage, 1);
      continue;
    }
    load.beads = std::max(load.beads, stage.beads);
    if (!ready) load.rest_s += estimate.StageSeconds(stage, 1);
  }
  return load;
}

std::vector<RunLoad> LoadsOf(const std::vector<SweepRun>& runs, BedCache* beds) {
  std::vector<RunLoad> loads;
  for (const SweepRun& run : runs) {
    try {
      const ResourceEstimate estimate = EstimateResources(run.scene);
      std::vector<std::string> cached;
      for (const StageEstimate& stage : estimate.stages)
        if (beds && beds->Contains(stage.hash)) cached.push_back(stage.hash);
      loads.push_back(LoadOf(estimate, run.beds.source_hash, cached));
    } catch (const std::exception&) {  // an imported bed that cannot be read: it fails later
      RunLoad unknown;
      unknown.source_hash = run.beds.source_hash;
      loads.push_back(unknown);
    }
  }
  return loads;
}

int ThreadsMax(const RunLoad& load, bool preparing_source, int cores) {
  if (!load.known) return std::max(cores, 1);
  return std::min(std::max(cores, 1),
                  dem::ThreadsFedBy(preparing_source ? load.source_beads : load.beads));
}

std::vector<std::size_t> StartOrder(const std::vector<RunLoad>& runs) {
  // Source beds in the order the sweep first names them, each with its runs heaviest first;
  // the runs without one (bare plates, imported beds) last in each round.
  std::vector<std::string> sources;
  std::map<std::string, std::vector<std::size_t>> by_source;
  for (std::size_t k = 0; k < runs.size(); ++k) {
    auto [it, added] = by_source.try_emplace(runs[k].source_hash);
    if (added && !runs[k].source_hash.empty()) sources.push_back(runs[k].source_hash);
    it->second.push_back(k);
  }
  if (by_source.count("")) sources.push_back("");
  for (auto& [hash, list] : by_source)
    std::stable_sort(list.begin(), list.end(),
                     [&](std::size_t a, std::size_t b) { return runs[a].rest_s > runs[b].rest_s; });
  std::vector<std::size_t> order;
  for (std::size_t round = 0; order.size() < runs.size(); ++round)
    for (const std::string& hash : sources)
      if (round < by_source[hash].size()) order.push_back(by_source[hash][round]);
  return order;
}

double PredictedSpeedup(int threads) {
  const double p = std::max(threads, 1);
  return 1.0 / (kStepSerialFraction + (1.0 - kStepSerialFraction) / p);
}

namespace {

// One run as the plan plays it.
struct PlayedRun {
  std::size_t run;
  bool preparing = false;  // preparing its source bed now
  double left_s = 0;       // one thread's seconds left of its present part
  std::size_t planned;     // its entry in the plan
  bool shared = false;     // has had its first share of the cores
};

}  // namespace

SchedulePlan PlanSchedule(const std::vector<RunLoad>& runs, const std::vector<std::size_t>& order,
                          int cores, int workers) {
  SchedulePlan plan;
  plan.cores = std::max(cores, 1);
  const auto at_once =
      static_cast<std::size_t>(workers > 0 ? std::min(workers, plan.cores) : plan.cores);
  std::set<std::string> ready, preparing;
  std::map<std::string, double> source_work;  // each source bed is prepared once
  for (const RunLoad& run : runs) {
    if (run.source_hash.empty() || run.source_s <= 0.0) ready.insert(run.source_hash);
    source_work[run.source_hash] = std::max(source_work[run.source_hash], run.source_s);
    plan.one_thread_s += run.rest_s;
  }
  for (const auto& [hash, seconds] : source_work) plan.one_thread_s += seconds;
  std::vector<std::size_t> queue = order;
  std::vector<PlayedRun> running;
  double now = 0.0;
  while (!queue.empty() || !running.empty()) {
    // Start what may start, in order, as the queue does (RunQueue::Next).
    for (auto it = queue.begin(); it != queue.end() && running.size() < at_once;) {
      const RunLoad& load = runs[*it];
      const bool source_ready = ready.count(load.source_hash) > 0;
      if (!source_ready && preparing.count(load.source_hash)) {
        ++it;  // it would only wait for the bed another run prepares
        continue;
      }
      if (!source_ready) preparing.insert(load.source_hash);
      running.push_back(
          {*it, !source_ready, source_ready ? load.rest_s : load.source_s, plan.runs.size()});
      plan.runs.push_back({*it, !source_ready, now, 0.0, 1});
      it = queue.erase(it);
    }
    // Share the cores as the queue does (RunQueue::ShareCoresLocked).
    std::vector<CoreClaim> claims;
    for (const PlayedRun& r : running) {
      CoreClaim claim{ThreadsMax(runs[r.run], r.preparing, plan.cores), 0};
      if (r.preparing)
        for (const std::size_t q : queue)
          claim.waiting += runs[q].source_hash == runs[r.run].source_hash;
      claims.push_back(claim);
    }
    const std::vector<int> threads = ShareCores(plan.cores, claims);
    // Run until the first part ends.
    double step = std::numeric_limits<double>::infinity();
    for (std::size_t k = 0; k < running.size(); ++k) {
      if (!running[k].shared) plan.runs[running[k].planned].threads_at_start = threads[k];
      running[k].shared = true;
      step = std::min(step, running[k].left_s / PredictedSpeedup(threads[k]));
    }
    now += step;
    for (std::size_t k = 0; k < running.size(); ++k)
      running[k].left_s -= step * PredictedSpeedup(threads[k]);
    for (auto it = running.begin(); it != running.end();) {
      if (it->left_s > 1e-9 * (1.0 + now)) {
        ++it;
        continue;
      }
      if (it->preparing) {  // its source bed is ready: the rest of its run follows
        plan.runs[it->planned].source_ready_s = now;
        ready.insert(runs[it->run].source_hash);
        preparing.erase(runs[it->run].source_hash);
        it->preparing = false;
        it->left_s = runs[it->run].rest_s;
        ++it;
        continue;
      }
      plan.runs[it->planned].end_s = now;
      it = running.erase(it);
    }
  }
  plan.wall_s = now;
  return plan;
}

}  // namespace dembuf
