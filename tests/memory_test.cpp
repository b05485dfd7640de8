// Peak memory of a run per agent (issue: 10 million boids in at most 64 bytes each, docs/performance.md#memory).
#include <malloc.h>
#include <sys/resource.h>

#include <cmath>
#include <string>

#include <catch2/catch.hpp>

#include "core/parallel.hpp"
#include "io/scenario.hpp"
#include "run.hpp"
#include "test_util.hpp"

using swarmsim::Json;
using swarmsim_test::TempDir;
using swarmsim_test::ThreadCountGuard;

namespace {

#if defined(__SANITIZE_ADDRESS__)
constexpr bool kSanitized = true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(memory_sanitizer) || __has_feature(thread_sanitizer)
constexpr bool kSanitized = true;
#else
constexpr bool kSanitized = false;
#endif
#else
constexpr bool kSanitized = false;
#endif

// the process's peak resident set so far, bytes (Linux: ru_maxrss in KiB)
double peakBytes() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return 1024.0 * static_cast<double>(u.ru_maxrss);
}

// n boids at the density of scenarios/boids_100k.json (about ten neighbours each), positions and velocities
// written, a checkpoint after every frame (so one is taken while every buffer of the step is allocated)
void runBoids(std::size_t n, const TempDir& dir) {
  const double s = std::cbrt(static_cast<double>(n) / 1e5);
  Json j = Json::parse(R"({
    "name": "memory", "seed": 7, "dt": 0.01, "frames": 3, "steps_per_frame": 1,
    "swarms": [{"name": "boids", "model": "boids", "initial_speed": 0.5,
                "spawn": {"type": "sphere", "center": [0, 0, 0]}, "params": {"jitter": 0.05}}],
    "output": {"quantities": ["position", "velocity"]}
  })");
  j["domain"] = {{"min", {-12 * s, -12 * s, -12 * s}}, {"max", {12 * s, 12 * s, 12 * s}}};
  j["swarms"][0]["count"] = n;
  j["swarms"][0]["spawn"]["radius"] = 6.463 * s;
  const swarmsim::Scenario sc = swarmsim::parseScenario(j, dir.file("memory.json"));
  swarmsim::RunOptions opt;
  opt.output = dir.file("memory_" + std::to_string(n) + ".h5");
  opt.quiet = true;
  opt.checkpointSeconds = 0.0;
  const swarmsim::RunResult r = swarmsim::runScenario(sc, opt);
  REQUIRE(r.frames == 3);
}

}  // namespace

TEST_CASE("Memory: a boids run takes at most 58 bytes per agent beyond a fixed amount (state, grid, scratch, "
          "writer, checkpoints)",
          "[memory]") {
  if (kSanitized) {
    WARN("not measured under a sanitizer (its shadow memory grows with the heap)");
    return;
  }
  // the peak after a run of 1M agents, then after one of 3M: their difference is what 2M more agents take
  // (the fixed amount: libraries, the 12 MiB writer block, thread stacks, cancels out). 58 bytes beyond
  // the ~50 MB fixed amount is 63 bytes per agent in all at 10M agents.
  // allocations of 1 MiB and more straight from the system and back, as those of a 10M run are (beyond
  // glibc's largest automatic threshold): else a freed array of the first run may stay in the heap
  mallopt(M_MMAP_THRESHOLD, 1 << 20);
  // a process's peak only grows: after other tests in the same process (the whole test binary at once, not
  // ctest's one test per process) it may already be above both runs' peaks, and the difference means nothing
  const double before = peakBytes();
  if (before > 200.0 * 1048576.0) {
    WARN("not measured: this process already peaked at " << before / 1048576.0
                                                         << " MiB before the runs (run this test alone, as ctest does)");
    return;
  }
  ThreadCountGuard guard;
  swarmsim::setThreadCount(2);
  TempDir dir;
  runBoids(1000000, dir);
  const double small = peakBytes();
  runBoids(3000000, dir);
  const double large = peakBytes();
  const double perAgent = (large - small) / 2e6;
  INFO("peak " << small / 1048576.0 << " MiB at 1M agents, " << large / 1048576.0 << " MiB at 3M: " << perAgent
               << " bytes per agent");
  CHECK(perAgent > 28.0);  // at least the state itself (positions, velocities, ids): the measure works
  CHECK(perAgent <= 58.0);
}
