#include "core/threads.hpp"

#include <sched.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <fstream>
#include <sstream>
#include <string>

#include "core/parallel.hpp"

namespace swarmsim {

namespace {

double wallNow() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

// the cgroup CPU quota in CPUs (v2 cpu.max, then v1 cfs), 0 when unlimited or unknown
double cgroupQuota() {
  const char* root = std::getenv("SWARMSIM_CGROUP_ROOT");  // for tests: a fake /sys/fs/cgroup
  const std::string base = root ? root : "/sys/fs/cgroup";
  // the process's own cgroup (v2: one line "0::/path")
  std::string rel;
  {
    std::ifstream cg(root ? base + "/self.cgroup" : "/proc/self/cgroup");
    std::string line;
    while (std::getline(cg, line)) {
      if (line.rfind("0::", 0) == 0) rel = line.substr(3);
    }
  }
  for (std::string dir = base + rel;; dir = dir.substr(0, dir.rfind('/'))) {
    std::ifstream f(dir + "/cpu.max");
    std::string quota, period;
    if (f >> quota >> period && quota != "max") {
      const double q = std::atof(quota.c_str()), p = std::atof(period.c_str());
      if (q > 0 && p > 0) return q / p;
    }
    if (dir.size() <= base.size()) break;
  }
  std::ifstream q(base + "/cpu/cpu.cfs_quota_us"), p(base + "/cpu/cpu.cfs_period_us");
  double quota = -1, period = 0;
  if (q >> quota && p >> period && quota > 0 && period > 0) return quota / period;
  return 0.0;
}

}  // namespace

int availableCpus() {
  int n = 0;
  cpu_set_t set;
  CPU_ZERO(&set);
  if (sched_getaffinity(0, sizeof set, &set) == 0) n = CPU_COUNT(&set);
  if (n <= 0) n = static_cast<int>(std::max(1L, sysconf(_SC_NPROCESSORS_ONLN)));
  const double quota = cgroupQuota();
  if (quota > 0.0) n = std::min(n, std::max(1, static_cast<int>(std::ceil(quota - 1e-9))));
  return std::max(1, n);
}

namespace {
bool gAdapt = true;
}  // namespace
void setThreadAdaptation(bool on) { gAdapt = on; }
bool threadAdaptation() { return gAdapt; }

int defaultThreadCount() {
  const char* env = std::getenv("OMP_NUM_THREADS");
  if (env && *env) return threadCount();
  return availableCpus();
}

namespace {

struct Governor {
  bool init = false, adapt = false;
  int max = 1, current = 1, cpus = 1;
  double lastWall = 0.0, lastBusy = 0.0, lastOwn = 0.0, others = 0.0;
  unsigned long long mask[16] = {};  // up to 1,024 CPUs

  void setup() {
    init = true;
    cpu_set_t set;
    CPU_ZERO(&set);
    int count = 0;
    if (sched_getaffinity(0, sizeof set, &set) == 0) {
      for (int c = 0; c < 1024 && c < CPU_SETSIZE; ++c) {
        if (CPU_ISSET(c, &set)) {
          mask[c / 64] |= 1ULL << (c % 64);
          ++count;
        }
      }
    }
    cpus = std::min(std::max(1, count), availableCpus());
    adapt = count > 0 && std::getenv("SWARMSIM_FIXED_THREADS") == nullptr && sample(lastBusy, lastOwn);
    lastWall = wallNow();
  }

  // busy CPU seconds of our CPUs (/proc/stat) and our own CPU seconds
  bool sample(double& busy, double& own) const {
    std::ifstream f("/proc/stat");
    if (!f) return false;
    static const double tick = static_cast<double>(sysconf(_SC_CLK_TCK));
    std::string line;
    busy = 0.0;
    bool any = false;
    while (std::getline(f, line)) {
      if (line.rfind("cpu", 0) != 0 || line.size() < 4 || line[3] < '0' || line[3] > '9') continue;
      std::istringstream in(line.substr(3));
      int cpu = -1;
      unsigned long long user = 0, nice = 0, system = 0, idle = 0, iowait = 0, irq = 0, softirq = 0, steal = 0;
      in >> cpu >> user >> nice >> system >> idle >> iowait >> irq >> softirq >> steal;
      if (cpu < 0 || cpu >= 1024 || !(mask[cpu / 64] >> (cpu % 64) & 1ULL)) continue;
      busy += static_cast<double>(user + nice + system + irq + softirq + steal) / tick;
      any = true;
    }
    timespec ts{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    own = static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
    return any;
  }

  int wanted() const {
    if (!adapt || !gAdapt) return max;
    const int free = static_cast<int>(std::floor(static_cast<double>(cpus) - others + 0.5));
    return std::clamp(free, 1, max);
  }

  void apply() {
    current = wanted();
    setThreadCount(current);
  }
};

Governor& governor() {
  static Governor g;
  if (!g.init) g.setup();
  return g;
}

}  // namespace

void requestThreads(int n) {
  Governor& g = governor();
  g.max = std::max(1, n);
  g.apply();
}

void threadTick() {
  Governor& g = governor();
  if (!g.adapt || !gAdapt || g.max <= 1) return;
  const double now = wallNow();
  const double wall = now - g.lastWall;
  if (wall < 0.5) return;
  double busy = 0.0, own = 0.0;
  if (!g.sample(busy, own)) return;
  // CPUs that other processes kept busy over the interval
  g.others = std::max(0.0, ((busy - g.lastBusy) - (own - g.lastOwn)) / wall);
  g.lastWall = now;
  g.lastBusy = busy;
  g.lastOwn = own;
  g.apply();
}

int threadsInUse() { return governor().current; }

}  // namespace swarmsim
