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
  double othersError = 0.0;  // how far `others` may be off: the ticks of /proc/stat over the look
  // threadTick reads the clock only every `stride` calls, so a step of a few
  // agents (~100 ns) does not pay for it; the stride adapts to ~1-20 ms a look
  double lastLook = 0.0;
  long calls = 0, stride = 1;
  long long ticks = 0;  // steps so far
  // on a busy machine: which of two team sizes steps faster, measured
  enum class Phase { kSettled, kProbing };
  Phase phase = Phase::kSettled;
  int alternative = 1;  // the team that fits the CPUs others leave free
  double phaseStart = 0.0, holdUntil = 0.0, hold = 5.0;
  int window = 0;           // of the measurement
  bool windowOpens = false;  // the next look starts the window
  long long freeSteps = 0, fullSteps = 0;
  double freeTime = 0.0, fullTime = 0.0;
  int lastAlternative = -1, lastChoice = -1;
  // the machine is looked at 0.1 s after a team is requested, then every 0.5 s
  double lookInterval = 0.1;
  bool looked = false;  // since the team was requested
  long long phaseTicks = 0;
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
      unsigned long long user = 0, nice = 0, system = 0, idle = 0, iowait = 0, irq = 0, softirq = 0;
      in >> cpu >> user >> nice >> system >> idle >> iowait >> irq >> softirq;
      if (cpu < 0 || cpu >= 1024 || !(mask[cpu / 64] >> (cpu % 64) & 1ULL)) continue;
      // steal (time the hypervisor gave to other machines) is not counted: it is
      // not a process here that our threads would compete with
      busy += static_cast<double>(user + nice + system + irq + softirq) / tick;
      any = true;
    }
    timespec ts{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    own = static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
    return any;
  }

  // the team that fits the CPUs other processes leave free. A CPU counts as
  // taken from 0.45 CPUs of others' time on: a process that wants a whole CPU
  // gets only half of one it shares with one of our threads.
  int freeTeam() const {
    // /proc/stat counts in clock ticks (1/100 s): over a short look each CPU's busy time is off by up
    // to a tick, and a tick is charged whole to whoever ran at it; twice that much of others' time
    // is not trusted (0.4 CPUs on 2 CPUs after 0.1 s, 0.08 after 0.5 s), so an idle machine is
    // never taken for a busy one while a process that holds a whole CPU still shows at 0.1 s
    const int taken = static_cast<int>(std::floor(std::max(0.0, others - othersError) + 0.55));
    return std::clamp(cpus - taken, 1, max);
  }

  void use(int n) {
    current = n;
    setThreadCount(n);
  }

  // Idle machine: the full team. Busy: whichever of the free-CPU team and the
  // full team steps faster (a team that shares CPUs with other work gets more
  // CPU time but waits at every barrier; which wins depends on the work per
  // parallel loop), measured in four windows of 0.2 s in the order free, full,
  // full, free (so a load that drifts during the measurement favours neither),
  // and kept for 5 s, then measured again; each time the same team wins the
  // hold doubles, up to 40 s.
  static constexpr int kWindows = 4;
  static bool windowIsFull(int w) { return w == 1 || w == 2; }
  void decide(double now) {
    if (!adapt || !gAdapt) return use(max);
    alternative = freeTeam();
    if (alternative != lastAlternative) {  // the load changed: measure again
      lastAlternative = alternative;
      holdUntil = 0.0;
      hold = 5.0;
      phase = Phase::kSettled;
    }
    if (alternative >= max) {
      phase = Phase::kSettled;
      if (current != max) use(max);
      return;
    }
    if (phase == Phase::kProbing && windowOpens) {
      // a window starts one look after its team was set, so the switch (threads waking,
      // the scheduler placing them) is not counted against either team
      windowOpens = false;
      phaseStart = now;
      phaseTicks = ticks;
      return;
    }
    const double elapsed = now - phaseStart;
    const long long steps = ticks - phaseTicks;
    if (phase == Phase::kSettled) {
      if (now < holdUntil) return;
      phase = Phase::kProbing;
      window = 0;
      freeSteps = fullSteps = 0;
      freeTime = fullTime = 0.0;
    } else {
      if (!(elapsed >= 0.2 && steps >= 2)) return;
      (windowIsFull(window) ? fullSteps : freeSteps) += steps;
      (windowIsFull(window) ? fullTime : freeTime) += elapsed;
      if (++window == kWindows) {
        const double freeRate = static_cast<double>(freeSteps) / freeTime;
        const double fullRate = static_cast<double>(fullSteps) / fullTime;
        // the full team only when it is clearly faster: within the machine's noise (a 0.2 s window of a
        // shared machine varies by 10-15 %) a tie goes to the free team, which never loses to 1 thread
        const int chosen = fullRate > 1.10 * freeRate ? max : alternative;
        hold = chosen == lastChoice ? std::min(2.0 * hold, 40.0) : 5.0;
        lastChoice = chosen;
        use(chosen);
        phase = Phase::kSettled;
        holdUntil = now + hold;
        return;
      }
    }
    use(windowIsFull(window) ? max : alternative);
    windowOpens = true;
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
  g.phase = Governor::Phase::kSettled;
  g.holdUntil = 0.0;
  g.hold = 5.0;
  g.lastAlternative = g.lastChoice = -1;
  g.use(g.adapt && gAdapt ? g.freeTeam() : g.max);  // the machine as last seen (idle: the full team), looked at again soon
  // a fresh look at the machine soon
  g.looked = false;
  g.lookInterval = 0.1;
  g.calls = 0;
  g.stride = 1;
  if (g.adapt && g.sample(g.lastBusy, g.lastOwn)) g.lastWall = wallNow();
}

bool threadsSettled() {
  Governor& g = governor();
  if (!g.adapt || !gAdapt || g.max <= 1) return true;
  return g.looked && g.phase == Governor::Phase::kSettled;
}

void threadTick() {
  Governor& g = governor();
  if (!g.adapt || !gAdapt || g.max <= 1) return;
  ++g.ticks;
  if (++g.calls < g.stride) return;
  g.calls = 0;
  const double now = wallNow();
  const double sinceLook = now - g.lastLook;
  g.lastLook = now;
  if (sinceLook < 0.001) g.stride = std::min(g.stride * 2, 1L << 20);
  if (sinceLook > 0.02) g.stride = std::max(g.stride / 2, 1L);
  const double wall = now - g.lastWall;
  if (wall >= g.lookInterval) {
    double busy = 0.0, own = 0.0;
    if (g.sample(busy, own)) {
      g.looked = true;
      g.lookInterval = 0.5;
      // CPUs that other processes kept busy over the interval
      g.others = std::max(0.0, ((busy - g.lastBusy) - (own - g.lastOwn)) / wall);
      static const double hz = static_cast<double>(sysconf(_SC_CLK_TCK));
      g.othersError = 2.0 * static_cast<double>(g.cpus) / (hz * wall);
      g.lastWall = now;
      g.lastBusy = busy;
      g.lastOwn = own;
    }
  }
  g.decide(now);
}

int threadsInUse() { return governor().current; }

}  // namespace swarmsim
