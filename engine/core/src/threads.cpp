#include "dembuf/core/threads.h"

#include <omp.h>
#include <sched.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>

namespace dembuf::dem {

namespace {

// Hand-written: no Debian library reads a control group's CPU quota for a C++ program, and
// the two files it takes are a line each.

// The CPU quota of cgroup v2 at `dir` and its parents: the smallest ceil(quota / period) of
// their cpu.max files ("max 100000" means none).
double CgroupV2Quota(std::string dir) {
  double cpus = std::numeric_limits<double>::infinity();
  while (true) {
    std::ifstream file("/sys/fs/cgroup" + dir + "/cpu.max");
    std::string quota;
    double period = 0.0;
    if (file >> quota >> period && quota != "max" && period > 0.0)
      cpus = std::min(cpus, std::ceil(std::stod(quota) / period));
    if (dir.empty() || dir == "/") break;
    dir = dir.substr(0, dir.rfind('/'));
  }
  return cpus;
}

// The same for cgroup v1's cpu controller (cpu.cfs_quota_us, -1 for none).
double CgroupV1Quota(const std::string& dir) {
  for (const char* mount : {"/sys/fs/cgroup/cpu,cpuacct", "/sys/fs/cgroup/cpu"}) {
    std::ifstream quota_file(std::string(mount) + dir + "/cpu.cfs_quota_us");
    std::ifstream period_file(std::string(mount) + dir + "/cpu.cfs_period_us");
    double quota = -1.0, period = 0.0;
    if (quota_file >> quota && period_file >> period && quota > 0.0 && period > 0.0)
      return std::ceil(quota / period);
  }
  return std::numeric_limits<double>::infinity();
}

// The quota of this process's control group (/proc/self/cgroup: "0::/path" for v2,
// "N:cpu,cpuacct:/path" for v1), in CPUs; infinity without one.
double CgroupQuota() {
  std::ifstream self("/proc/self/cgroup");
  std::string line;
  double cpus = std::numeric_limits<double>::infinity();
  while (std::getline(self, line)) {
    const std::size_t first = line.find(':'), second = line.find(':', first + 1);
    if (first == std::string::npos || second == std::string::npos) continue;
    const std::string controllers = line.substr(first + 1, second - first - 1);
    const std::string path = line.substr(second + 1);
    if (controllers.empty())
      cpus = std::min(cpus, CgroupV2Quota(path));
    else if (("," + controllers + ",").find(",cpu,") != std::string::npos)
      cpus = std::min(cpus, CgroupV1Quota(path));
  }
  return cpus;
}

int CountUsableCpus() {
  int cpus = 1;
  cpu_set_t mask;
  if (sched_getaffinity(0, sizeof mask, &mask) == 0) cpus = std::max(1, CPU_COUNT(&mask));
  const double quota = CgroupQuota();
  if (quota >= 1.0 && quota < cpus) cpus = static_cast<int>(quota);
  return cpus;
}

}  // namespace

int UsableCpus() {
  static const int cpus = CountUsableCpus();
  return cpus;
}

int EffectiveThreads(int requested, std::size_t beads, int cpus) {
  const int asked = requested > 0 ? requested : omp_get_max_threads();
  return std::max(1,
                  std::min({asked, std::max(cpus, 1), ThreadsFedBy(static_cast<double>(beads))}));
}

}  // namespace dembuf::dem
