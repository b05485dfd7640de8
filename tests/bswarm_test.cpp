// The BSwarm force model (wang2015): hand-worked friction and response forces,
// schedules, polarisation, parameter reading, and end-to-end runs of the paper's
// scenarios (phase transition, escape, obstacles, determinism). The interaction
// force has its own tests (bswarm_interaction_test.cpp), ORCA too (orca_test.cpp).
#include "models/bswarm/bswarm.hpp"

#include <catch2/catch.hpp>
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "core/error.hpp"
#include "core/parallel.hpp"
#include "geometry/signed_distance.hpp"
#include "io/scenario.hpp"
#include "io/trajectory_reader.hpp"
#include "run.hpp"
#include "test_util.hpp"

using swarmsim::Json;
using swarmsim::Scenario;
using swarmsim::Simulation;
using swarmsim::StimulusSpec;
using swarmsim::Vec3;

namespace {

const std::string kScenarios = std::string(SWARMSIM_SOURCE_DIR) + "/scenarios/";
constexpr float kPi = 3.14159265f;

bool near3(const Vec3& a, const Vec3& b, float tol = 1e-5f) { return (a - b).norm() <= tol; }

StimulusSpec pointStimulus(StimulusSpec::Kind kind, double radius = 0.0) {
  StimulusSpec s;
  s.kind = kind;
  s.radius = radius;
  s.path.times = {0.0};
  s.path.values = {Eigen::Vector3d(10, 0, 0)};
  return s;
}

// a small bswarm scenario with the given params overrides
Json smallBswarm(const Json& params, int count) {
  Json p = {{"noise", {{"gain", 0.0}, {"cells", {8, 8, 8}}}}, {"orca", {{"radius", 0.05}, {"neighbor_distance", 0.5}}}};
  for (const auto& it : params.items()) p[it.key()] = it.value();
  return {{"dt", 0.01},
          {"frames", 2},
          {"domain", {{"min", {0, 0, 0}}, {"max", {10, 10, 10}}}},
          {"swarms",
           {{{"name", "s"},
             {"count", count},
             {"model", "bswarm"},
             {"spawn", {{"type", "sphere"}, {"center", {5, 5, 5}}, {"radius", 1.0}}},
             {"params", p}}}}};
}

struct ThreadCountGuard {
  int saved = swarmsim::threadCount();
  ~ThreadCountGuard() { swarmsim::setThreadCount(saved); }
};

}  // namespace

TEST_CASE("BSwarm friction is -gamma |v| v", "[bswarm]") {
  // v = (3, 4, 0): |v| = 5, gamma = 2: F = -2 * 5 * (3, 4, 0) = (-30, -40, 0)
  CHECK(near3(swarmsim::frictionForce(Vec3(3, 4, 0), 2.0f), Vec3(-30, -40, 0)));
  CHECK(near3(swarmsim::frictionForce(Vec3::Zero(), 2.0f), Vec3::Zero()));
}

TEST_CASE("BSwarm response force: pursuit, escape with rotation, visual range, attached stimulus", "[bswarm]") {
  std::vector<StimulusSpec> stimuli;
  std::vector<Vec3> centers = {Vec3(10, 0, 0)};
  swarmsim::AttachedStimulus none;
  swarmsim::ResponseInputs in;
  in.lambdaRes = 2.0f;
  in.rRes = 20.0f;
  in.stimuli = &stimuli;
  in.centers = centers.data();
  in.attached = &none;
  in.escapeAxis = Vec3::UnitZ();
  const Vec3 x = Vec3::Zero(), v(1, 0, 0);

  SECTION("pursuit: straight toward the attractor, lambda_res long") {
    stimuli = {pointStimulus(StimulusSpec::Kind::kAttractor)};
    // r̂_ie = (x - e)/|x - e| = (-1, 0, 0); F = -lambda r̂ = (2, 0, 0)
    CHECK(near3(swarmsim::responseForce(in, x, v, 0.0f), Vec3(2, 0, 0)));
  }
  SECTION("escape: away from the predator, rotated about the axis") {
    stimuli = {pointStimulus(StimulusSpec::Kind::kPredator)};
    // theta = 0: F = lambda r̂ = (-2, 0, 0)
    CHECK(near3(swarmsim::responseForce(in, x, v, 0.0f), Vec3(-2, 0, 0)));
    // theta = -90 deg about z: R(-1, 0, 0) = cos(-90)(-1,0,0) + sin(-90) z x (-1,0,0) = -(0,-1,0) = (0, 1, 0)
    CHECK(near3(swarmsim::responseForce(in, x, v, -kPi / 2), Vec3(0, 2, 0)));
    // theta = -45 deg: (-cos 45, sin 45, 0) * 2
    const float c = std::sqrt(0.5f);
    CHECK(near3(swarmsim::responseForce(in, x, v, -kPi / 4), Vec3(-2 * c, 2 * c, 0)));
  }
  SECTION("Heaviside: nothing beyond the visual range; spheres count from their surface") {
    stimuli = {pointStimulus(StimulusSpec::Kind::kAttractor)};
    in.rRes = 9.9f;  // the point is 10 m away
    CHECK(swarmsim::responseForce(in, x, v, 0.0f).norm() == 0.0f);
    stimuli = {pointStimulus(StimulusSpec::Kind::kAttractor, 0.5)};  // surface 9.5 m away
    CHECK(near3(swarmsim::responseForce(in, x, v, 0.0f), Vec3(2, 0, 0)));
    stimuli[0].visualRange = 9.0;  // its own range wins over r_res
    CHECK(swarmsim::responseForce(in, x, v, 0.0f).norm() == 0.0f);
  }
  SECTION("weights and several stimuli add up") {
    stimuli = {pointStimulus(StimulusSpec::Kind::kAttractor), pointStimulus(StimulusSpec::Kind::kAttractor)};
    stimuli[1].weight = 0.5;
    centers = {Vec3(10, 0, 0), Vec3(0, 0, -3)};
    in.centers = centers.data();
    // (2, 0, 0) + 0.5 * 2 * (0, 0, -1)
    CHECK(near3(swarmsim::responseForce(in, x, v, 0.0f), Vec3(2, 0, -1)));
  }
  SECTION("an attractor carried ahead, turned 90 degrees left, pulls sideways") {
    swarmsim::AttachedStimulus ahead;
    ahead.enabled = true;
    ahead.distance = 1.0;
    ahead.angle = 90.0;
    in.attached = &ahead;
    // heading (1, 0, 0) turned +90 deg about z: (0, 1, 0); pursuit of it: lambda (0, 1, 0)
    CHECK(near3(swarmsim::responseForce(in, x, v, 0.0f), Vec3(0, 2, 0)));
    ahead.distance = 30.0;  // beyond r_res: unseen
    CHECK(swarmsim::responseForce(in, x, v, 0.0f).norm() == 0.0f);
  }
}

TEST_CASE("BSwarm schedules interpolate each parameter between its own keys", "[bswarm]") {
  swarmsim::BswarmSchedule s;
  s.tracks = {{"lambda_ali", {10.0, 30.0}, {0.0, 10.0}}, {"gain", {0.0}, {0.5}}};
  swarmsim::BswarmDynamic d;
  d.gamma = 7.0;
  s.apply(0.0, d);
  CHECK(d.lambdaAli == 0.0);
  CHECK(d.gain == 0.5);
  s.apply(20.0, d);
  CHECK(d.lambdaAli == Approx(5.0));
  s.apply(99.0, d);
  CHECK(d.lambdaAli == 10.0);
  CHECK(d.gamma == 7.0);  // unscheduled parameters keep their values
}

TEST_CASE("BSwarm polarisation", "[bswarm]") {
  const std::vector<float> vx = {1, 2, 0.5f, 0}, vy = {0, 0, 0, 0}, vz = {0, 0, 0, 0};
  // three unit vectors (1, 0, 0) and a zero velocity: |3 (1, 0, 0)| / 4
  CHECK(swarmsim::polarisation(vx.data(), vy.data(), vz.data(), 4) == Approx(0.75));
  const std::vector<float> ox = {1, -1}, oy = {0, 0}, oz = {0, 0};
  CHECK(swarmsim::polarisation(ox.data(), oy.data(), oz.data(), 2) == Approx(0.0).margin(1e-12));
  CHECK(swarmsim::polarisation(nullptr, nullptr, nullptr, 0) == 0.0);
}

TEST_CASE("BSwarm reads radii as absolute values or as the paper's differences", "[bswarm]") {
  const auto params = [](const Json& p) {
    const Scenario sc = swarmsim::parseScenario(smallBswarm(p, 3), "radii.json");
    return sc.resolved["swarms"][0]["params"];
  };
  const Json diff = params({{"r_rep", 0.2}, {"dr_ali", 1.0}, {"dr_att", 5.0}});
  CHECK(diff["r_ali"].get<double>() == Approx(1.2));
  CHECK(diff["r_att"].get<double>() == Approx(6.2));
  const Json abs = params({{"r_rep", 0.2}, {"r_ali", 1.0}, {"r_att", 5.0}});
  CHECK(abs["r_ali"].get<double>() == Approx(1.0));
  CHECK(abs["r_att"].get<double>() == Approx(5.0));

  const auto fails = [](const Json& p, const std::string& expected) {
    INFO(p.dump());
    try {
      swarmsim::parseScenario(smallBswarm(p, 3), "bad.json");
      FAIL("no error");
    } catch (const swarmsim::InputError& e) {
      CHECK_THAT(e.what(), Catch::Contains(expected));
    }
  };
  fails({{"r_ali", 1.0}, {"dr_ali", 1.0}}, "swarms[0].params.dr_ali: give r_ali (absolute) or dr_ali");
  fails({{"r_rep", 0.5}, {"r_ali", 0.2}}, "swarms[0].params.r_ali: expected r_ali >= r_rep");
  fails({{"schedule", {{{"time", 1.0}}}}}, "swarms[0].params.schedule[0].time: a schedule key must set");
  fails({{"schedule", {{{"time", 2.0}, {"gain", 1.0}}, {{"time", 1.0}, {"gain", 0.0}}}}}, "later than the previous");
  fails({{"stimuli", {{{"type", "food"}, {"center", {1, 2, 3}}}}}}, "swarms[0].params.stimuli[0].type");
  fails({{"stimuli", {{{"type", "predator"}}}}}, "swarms[0].params.stimuli[0].center");
  fails({{"noise", {{"type", "pink"}}}}, "swarms[0].params.noise.type");
}

TEST_CASE("BSwarm phase transition: polarisation rises from below 0.3 to above 0.7", "[bswarm][scenario]") {
  const Scenario sc = swarmsim::loadScenario(kScenarios + "phase_transition.json");
  Simulation sim(sc);
  std::vector<std::vector<double>> stats;
  std::vector<double> polar;  // per frame
  for (std::int64_t f = 1; f < sc.frames; ++f) {
    for (std::int64_t k = 0; k < sc.stepsPerFrame; ++k) sim.step();
    sim.takeFrameStats(stats);
    polar.push_back(stats[0][0]);
  }
  // the mean over the first 5 s (before the schedule starts) and the last 5 s
  const std::size_t perSecond =
      static_cast<std::size_t>(std::lround(1.0 / (sc.dt * static_cast<double>(sc.stepsPerFrame))));
  double early = 0.0, late = 0.0;
  for (std::size_t i = perSecond; i < 6 * perSecond; ++i) early += polar[i] / (5.0 * static_cast<double>(perSecond));
  for (std::size_t i = polar.size() - 5 * perSecond; i < polar.size(); ++i)
    late += polar[i] / (5.0 * static_cast<double>(perSecond));
  WARN("phase_transition polarisation: mean " << early << " over t = 1-6 s, " << late << " over the last 5 s");
  CHECK(early < 0.3);
  CHECK(late > 0.7);
}

TEST_CASE("BSwarm escape: the predator rarely gets within its visual range of the swarm", "[bswarm][scenario]") {
  const Scenario sc = swarmsim::loadScenario(kScenarios + "escape.json");
  Simulation sim(sc);
  std::vector<std::vector<double>> stats;
  int frames = 0, clear = 0;
  double closest = 1e9;
  const double range = sc.resolved["swarms"][0]["params"]["r_res"].get<double>();
  for (std::int64_t f = 1; f < sc.frames; ++f) {
    for (std::int64_t k = 0; k < sc.stepsPerFrame; ++k) sim.step();
    sim.takeFrameStats(stats);
    const double d = stats[0][1];  // stimulus_distance: predator surface to the nearest fly
    closest = std::min(closest, d);
    ++frames;
    clear += d > range ? 1 : 0;
  }
  const double fraction = static_cast<double>(clear) / frames;
  WARN("escape: predator-to-nearest-fly distance above r_res in " << 100.0 * fraction << " % of frames; closest "
                                                                  << closest << " m");
  CHECK(fraction > 0.5);
  CHECK(closest > 0.0);  // the solid predator never touches a fly
}

TEST_CASE("BSwarm scenarios keep every insect out of the obstacles", "[bswarm][scenario]") {
  const std::string name = GENERATE(std::string("moths"), std::string("bats"), std::string("locust_migration"));
  INFO(name);
  const Scenario sc = swarmsim::loadScenario(kScenarios + name + ".json");
  Simulation sim(sc);
  std::array<int, 3> n{};
  for (int a = 0; a < 3; ++a) n[a] = static_cast<int>(std::ceil(sc.domain.extent()[a] / 0.1));
  const auto sdf =
      swarmsim::signedDistance(*sc.obstacles, swarmsim::GridSpec::covering(sc.domain.min, sc.domain.max, n));
  const double radius = sc.resolved["swarms"][0]["params"]["orca"]["radius"].get<double>();
  float worst = 1e9f;
  for (int f = 0; f < 100; ++f) {
    for (std::int64_t k = 0; k < sc.stepsPerFrame; ++k) sim.step();
    const auto& s = sim.swarms()[0];
    for (std::size_t i = 0; i < s.size(); ++i) worst = std::min(worst, sdf.sample(s.position(i)));
  }
  WARN(name << ": smallest signed distance of an insect over 100 frames " << worst << " m (radius " << radius << ")");
  CHECK(worst > -0.1f);  // within the 0.1 m grid's resolution of the surface, never deep inside
}

TEST_CASE("BSwarm runs are bit-identical for 1 and 2 threads", "[bswarm][determinism]") {
  ThreadCountGuard guard;
  swarmsim_test::TempDir dir;
  Json j = Json::parse(R"({"name": "det", "seed": 5, "dt": 0.01, "frames": 8, "steps_per_frame": 2,
    "domain": {"min": [0, 0, 0], "max": [20, 20, 20]},
    "obstacles": [{"type": "sphere", "center": [10, 10, 10], "radius": 1.0}],
    "swarms": [{"name": "flies", "count": 3000, "model": "bswarm", "initial_speed": 0.5,
      "spawn": {"type": "sphere", "center": [10, 10, 13], "radius": 2.0},
      "params": {"r_rep": 0.1, "r_ali": 0.3, "r_att": 2.0, "lambda_ali": 2.0, "lambda_res": 5.0, "r_res": 4.0,
                 "noise": {"type": "gaussian", "gain": 1.0},
                 "stimuli": [{"type": "predator", "radius": 0.5, "keyframes": [{"time": 0, "center": [4, 10, 13]},
                                                                              {"time": 1, "center": [16, 10, 13]}]}],
                 "orca": {"radius": 0.02, "neighbor_distance": 0.2}}}]})");
  const Scenario sc = swarmsim::parseScenario(j, dir.file("det.json"));
  std::vector<std::string> files;
  for (int t : {1, 2}) {
    swarmsim::setThreadCount(t);
    swarmsim::RunOptions opt;
    opt.output = dir.file("t" + std::to_string(t) + ".h5");
    opt.quiet = true;
    swarmsim::runScenario(sc, opt);
    files.push_back(opt.output);
  }
  for (const std::string d : {"swarms/flies/position", "swarms/flies/velocity"}) {
    const auto a = swarmsim::readFloatDataset(files[0], d), b = swarmsim::readFloatDataset(files[1], d);
    INFO(d);
    REQUIRE(a.size() == b.size());
    CHECK(std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0);
    CHECK(std::memcmp(a.data(), a.data() + 7 * 3000 * 3, 3000 * 3 * sizeof(float)) != 0);  // it moved
  }
}
