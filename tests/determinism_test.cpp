// Results must not depend on the number of threads: the same scenario run
// with 1, 2 and 3 threads gives bit-identical trajectories.
#include <cstring>
#include <string>
#include <vector>

#include <catch2/catch.hpp>

#include "core/parallel.hpp"
#include "io/scenario.hpp"
#include "io/trajectory_reader.hpp"
#include "run.hpp"
#include "test_util.hpp"

using swarmsim::Json;
using swarmsim_test::TempDir;
using swarmsim_test::ThreadCountGuard;

namespace {

// two interleaved swarms, 2,000 agents in all, with jitter and a response time
Json determinismScenario() {
  return Json::parse(R"({
    "name": "determinism", "seed": 2024, "dt": 0.01, "frames": 12, "steps_per_frame": 2,
    "domain": {"min": [-2, -2, 0], "max": [2, 2, 3]},
    "swarms": [
      {"name": "midges", "count": 1300, "model": "boids", "initial_speed": 0.3,
       "spawn": {"type": "sphere", "center": [0, 0, 1.5], "radius": 0.6},
       "params": {"alignment": 0.01, "attraction": 0.0005, "centering": 0.5, "centering_radius": 0.6,
                  "jitter": 0.4, "response_time": 0.1}},
      {"name": "gnats", "count": 700, "model": "boids", "initial_speed": 0.5,
       "spawn": {"type": "box", "min": [-0.5, -0.5, 1], "max": [0.5, 0.5, 2]},
       "params": {"speed": 0.4, "max_speed": 1.2, "repulsion_zone": 0.04, "jitter": 0.2,
                  "field_of_view": 300}}
    ]
  })");
}

bool sameBytes(const std::vector<float>& a, const std::vector<float>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

}  // namespace

TEST_CASE("Determinism across thread counts", "[determinism]") {
  ThreadCountGuard guard;
  TempDir dir;
  const swarmsim::Scenario sc = swarmsim::parseScenario(determinismScenario(), dir.file("determinism.json"));
  const std::vector<int> threads = {1, 2, 3};
  std::vector<std::string> files;
  for (int t : threads) {
    swarmsim::setThreadCount(t);
    REQUIRE(swarmsim::threadCount() == t);
    swarmsim::RunOptions opt;
    opt.output = dir.file("t" + std::to_string(t) + ".h5");
    opt.quiet = true;
    const auto r = swarmsim::runScenario(sc, opt);
    REQUIRE(r.frames == 12);
    files.push_back(opt.output);
  }
  const std::vector<std::string> datasets = {"swarms/midges/position", "swarms/midges/velocity",
                                             "swarms/gnats/position", "swarms/gnats/velocity"};
  for (const auto& d : datasets) {
    std::vector<std::uint64_t> shape;
    const auto ref = swarmsim::readFloatDataset(files[0], d, &shape);
    REQUIRE(shape.size() == 3u);
    CHECK(shape[0] == 12u);
    for (std::size_t i = 1; i < files.size(); ++i) {
      INFO(d << ": 1 thread vs " << threads[i] << " threads");
      CHECK(sameBytes(ref, swarmsim::readFloatDataset(files[i], d)));
    }
  }
  // the run really evolved (the comparison is not of static data) and the swarms differ
  const auto pos = swarmsim::readFloatDataset(files[0], "swarms/midges/position");
  const std::size_t frame = 1300 * 3;
  CHECK(std::memcmp(pos.data(), pos.data() + 11 * frame, frame * sizeof(float)) != 0);
}

TEST_CASE("Determinism of repeated runs in one process", "[determinism]") {
  // the model keeps scratch buffers between steps; a second Simulation in the
  // same process must not be affected by the first
  ThreadCountGuard guard;
  swarmsim::setThreadCount(2);
  const swarmsim::Scenario sc = swarmsim::parseScenario(determinismScenario(), "determinism.json");
  const auto runSteps = [&](int steps) {
    swarmsim::Simulation sim(sc);
    for (int i = 0; i < steps; ++i) sim.step();
    // positions by agent id
    std::vector<float> byId;
    for (const auto& s : sim.swarms()) {
      std::vector<float> rows(s.size() * 3);
      for (std::size_t i = 0; i < s.size(); ++i) {
        rows[3 * s.id[i]] = s.px[i];
        rows[3 * s.id[i] + 1] = s.py[i];
        rows[3 * s.id[i] + 2] = s.pz[i];
      }
      byId.insert(byId.end(), rows.begin(), rows.end());
    }
    return byId;
  };
  const auto a = runSteps(15);
  const auto b = runSteps(15);
  CHECK(sameBytes(a, b));
  swarmsim::setThreadCount(1);
  CHECK(sameBytes(a, runSteps(15)));
}
