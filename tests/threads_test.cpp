// Thread counts: the default follows CPU affinity and the cgroup CPU quota;
// the governor uses fewer threads while another process holds a CPU.
#include <sched.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <thread>
#include <vector>

#include <catch2/catch.hpp>

#include "core/parallel.hpp"
#include "core/threads.hpp"
#include "test_util.hpp"

using swarmsim_test::TempDir;

namespace {

// restores the affinity mask and an environment variable on scope exit
struct AffinityGuard {
  cpu_set_t saved;
  AffinityGuard() { sched_getaffinity(0, sizeof saved, &saved); }
  ~AffinityGuard() { sched_setaffinity(0, sizeof saved, &saved); }
};

}  // namespace

TEST_CASE("Default threads follow the CPU affinity", "[threads]") {
  AffinityGuard guard;
  cpu_set_t one;
  CPU_ZERO(&one);
  CPU_SET(sched_getcpu(), &one);
  REQUIRE(sched_setaffinity(0, sizeof one, &one) == 0);
  CHECK(swarmsim::availableCpus() == 1);
}

TEST_CASE("Default threads follow the cgroup CPU quota", "[threads]") {
  TempDir dir;
  namespace fs = std::filesystem;
  fs::create_directories(dir.path() / "job" / "step");
  swarmsim_test::writeText(dir.file("self.cgroup"), "0::/job/step\n");
  const int all = swarmsim::availableCpus();
  setenv("SWARMSIM_CGROUP_ROOT", dir.path().c_str(), 1);
  // unlimited at the process's own level, a quota of half a CPU above it (cgroup v2)
  swarmsim_test::writeText(dir.file("job/step/cpu.max"), "max 100000\n");
  swarmsim_test::writeText(dir.file("job/cpu.max"), "50000 100000\n");
  CHECK(swarmsim::availableCpus() == 1);
  // 1.5 CPUs: two threads (rounded up), never more than the affinity allows
  swarmsim_test::writeText(dir.file("job/cpu.max"), "150000 100000\n");
  CHECK(swarmsim::availableCpus() == std::min(all, 2));
  // cgroup v1
  fs::remove(dir.file("job/cpu.max"));
  fs::remove(dir.file("job/step/cpu.max"));
  fs::create_directories(dir.path() / "cpu");
  swarmsim_test::writeText(dir.file("cpu/cpu.cfs_quota_us"), "100000\n");
  swarmsim_test::writeText(dir.file("cpu/cpu.cfs_period_us"), "100000\n");
  CHECK(swarmsim::availableCpus() == 1);
  swarmsim_test::writeText(dir.file("cpu/cpu.cfs_quota_us"), "-1\n");
  CHECK(swarmsim::availableCpus() == all);
  unsetenv("SWARMSIM_CGROUP_ROOT");
}

TEST_CASE("The thread governor yields a CPU another process holds", "[threads]") {
  if (swarmsim::availableCpus() < 2) {
    WARN("skipped: needs two CPUs");
    return;
  }
  // a competing process spinning on one of our CPUs
  cpu_set_t set;
  sched_getaffinity(0, sizeof set, &set);
  int hogCpu = -1;
  for (int c = CPU_SETSIZE - 1; c >= 0 && hogCpu < 0; --c) {
    if (CPU_ISSET(c, &set)) hogCpu = c;
  }
  const pid_t hog = fork();
  REQUIRE(hog >= 0);
  if (hog == 0) {
    cpu_set_t one;
    CPU_ZERO(&one);
    CPU_SET(hogCpu, &one);
    sched_setaffinity(0, sizeof one, &one);
    volatile unsigned long x = 0;
    for (;;) x = x + 1;
  }
  swarmsim::setThreadAdaptation(true);
  swarmsim::requestThreads(2);
  CHECK_FALSE(swarmsim::threadsSettled());  // not looked at the machine yet: bench would keep warming up
  // steps of many short parallel loops (as the field model's at a few thousand insects): a thread that
  // shares its CPU with the hog holds every barrier up, so one thread steps faster, and the governor,
  // measuring both teams, must settle on it (machine seen busy after 0.1 s, then 4 windows of 0.2 s)
  std::vector<float> data(4096, 1.0f);
  const auto t0 = std::chrono::steady_clock::now();
  while (std::chrono::steady_clock::now() - t0 < std::chrono::milliseconds(2500)) {
    for (int loop = 0; loop < 50; ++loop) {
      swarmsim::parallelFor(data.size(), [&](std::size_t i) { data[i] = data[i] * 0.999f + 0.001f; });
    }
    swarmsim::threadTick();
  }
  const int busy = swarmsim::threadsInUse();
  const bool settled = swarmsim::threadsSettled();
  kill(hog, SIGKILL);
  waitpid(hog, nullptr, 0);
  CHECK(busy == 1);
  CHECK(settled);  // both teams measured, the choice held for 5 s
  CHECK(swarmsim::threadCount() == busy);
  // --fixed-threads: the requested count whatever the machine does
  swarmsim::setThreadAdaptation(false);
  swarmsim::requestThreads(2);
  CHECK(swarmsim::threadsInUse() == 2);
  CHECK(swarmsim::threadCount() == 2);
  swarmsim::setThreadAdaptation(true);
  swarmsim::requestThreads(swarmsim::defaultThreadCount());
}

TEST_CASE("parallelForBalanced visits every index once, and a thread done early takes the others' work",
          "[threads]") {
  const int saved = swarmsim::threadCount();
  for (const int threads : {1, 2, 3}) {
    swarmsim::setThreadCount(threads);
    for (const std::size_t n : {std::size_t{0}, std::size_t{100}, std::size_t{5000}, std::size_t{20011}}) {
      std::vector<int> visits(n, 0), by(n, -1);
      // the first range's indices are slow: with 2 or more threads another thread finishes first and takes some
      swarmsim::parallelForBalanced(n, 64, [&](std::size_t i) {
        ++visits[i];
        by[i] = swarmsim::threadIndex();
        if (threads > 1 && i < n / static_cast<std::size_t>(threads) && n >= 5000) {
          std::this_thread::sleep_for(std::chrono::microseconds(20));
        }
      });
      for (std::size_t i = 0; i < n; ++i) REQUIRE(visits[i] == 1);
      if (threads > 1 && n >= 5000) {
        std::size_t helped = 0;  // indices of the first range that another thread did
        for (std::size_t i = 0; i < n / static_cast<std::size_t>(threads); ++i) helped += by[i] != 0 ? 1 : 0;
        CHECK(helped > 0);
        // and the last range starts where schedule(static) starts it: with its own thread
        CHECK(by[n - 1] != 0);
      }
    }
  }
  swarmsim::setThreadCount(saved);
}
