// The field model (wang2014): reference values, MDE, goals, phototaxis, and
// end-to-end runs of the paper's scenarios (no agent inside an obstacle, the
// swarm reaches its goal, swarms cross, moving goals re-solve the cost field).
#include <catch2/catch.hpp>
#include <cmath>
#include <cstring>
#include <string>

#include "core/error.hpp"
#include "core/parallel.hpp"
#include "fields/grid3.hpp"
#include "geometry/obstacles.hpp"
#include "geometry/signed_distance.hpp"
#include "io/scenario.hpp"
#include "models/field/field.hpp"
#include "run.hpp"
#include "test_util.hpp"

using swarmsim::Json;
using swarmsim::Scenario;
using swarmsim::Simulation;

namespace {

const std::string kScenarios = std::string(SWARMSIM_SOURCE_DIR) + "/scenarios/";

// a small open box with an optional goal and the given params overrides
Json smallField(const Json& params, int count) {
  Json p = {{"speed", 1.0}, {"cost_cells", {20, 20, 20}}, {"noise", {{"gain", 0.0}, {"cells", {8, 8, 8}}}}};
  for (const auto& it : params.items()) p[it.key()] = it.value();
  return {{"dt", 0.05},
          {"frames", 2},
          {"domain", {{"min", {0, 0, 0}}, {"max", {10, 10, 10}}}},
          {"swarms",
           {{{"name", "s"},
             {"count", count},
             {"model", "field"},
             {"spawn", {{"type", "sphere"}, {"center", {5, 5, 5}}, {"radius", 0}}},
             {"params", p}}}}};
}

// fine signed distance of the scenario's obstacles, for checking agents independently of the model's grids
swarmsim::Grid3<float> fineDistance(const Scenario& sc, double cell) {
  std::array<int, 3> n{};
  for (int a = 0; a < 3; ++a) n[a] = static_cast<int>(std::ceil(sc.domain.extent()[a] / cell));
  return swarmsim::signedDistance(*sc.obstacles, swarmsim::GridSpec::covering(sc.domain.min, sc.domain.max, n));
}

// every step of the scenario's frames
void runWhole(Simulation& sim, const Scenario& sc) {
  const std::int64_t steps = (sc.frames - 1) * sc.stepsPerFrame;
  for (std::int64_t k = 0; k < steps; ++k) sim.step();
}

double insideFraction(const swarmsim::SwarmState& s, const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) {
  std::size_t in = 0;
  for (std::size_t i = 0; i < s.size(); ++i) {
    const Eigen::Vector3d p = s.position(i).cast<double>();
    if ((p - lo).minCoeff() >= 0.0 && (hi - p).minCoeff() >= 0.0) ++in;
  }
  return static_cast<double>(in) / static_cast<double>(s.size());
}

}  // namespace

TEST_CASE("Field model: bell function of eq. 6", "[field]") {
  CHECK(swarmsim::bell(-0.5) == 1.0);
  CHECK(swarmsim::bell(0.0) == 1.0);
  CHECK(swarmsim::bell(1.0) == Approx(0.0).margin(1e-12));  // 1 - 4/9 + 17/9 - 22/9 = 0
  // 1 - 4/9/64 + 17/9/16 - 22/9/4 = 0.5 (worked by hand)
  CHECK(swarmsim::bell(0.5) == Approx(0.5).margin(1e-6));
  CHECK(swarmsim::bell(2.0) == 0.0);
}

TEST_CASE("Field model: keyframed goals interpolate and hold", "[field]") {
  swarmsim::GoalSpec g;
  g.keyTimes = {1.0, 3.0};
  g.keyCenters = {Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(4, 2, 0)};
  CHECK((g.centerAt(0.0) - Eigen::Vector3d(0, 0, 0)).norm() == 0.0);
  CHECK((g.centerAt(2.0) - Eigen::Vector3d(2, 1, 0)).norm() < 1e-12);
  CHECK((g.centerAt(9.0) - Eigen::Vector3d(4, 2, 0)).norm() == 0.0);
}

TEST_CASE("Field model: MDE pushes a close pair to the minimum distance and records it", "[field]") {
  // two agents 0.1 m apart, no goal, no noise: one step of MDE with d_min 0.3
  // moves each by (0.3 - 0.1) / 2 = 0.1 along their line
  const std::string pairs = GENERATE(std::string("neighbours"), std::string("same_cell"));
  INFO("mde_pairs " << pairs);
  Json j = smallField({{"min_distance", 0.3}, {"mde_pairs", pairs}}, 2);
  j["swarms"][0]["spawn"] = {{"type", "box"}, {"min", {5, 5, 5}}, {"max", {5.1, 5, 5}}};
  const Scenario sc = swarmsim::parseScenario(j, "mde.json");
  Simulation sim(sc);
  const auto& s0 = sim.swarms()[0];
  const double before = (s0.position(0) - s0.position(1)).norm();
  REQUIRE(before < 0.3);
  sim.step();
  const auto& s = sim.swarms()[0];
  CHECK((s.position(0) - s.position(1)).norm() == Approx(0.3).margin(1e-5));
  std::vector<std::vector<double>> stats;
  sim.takeFrameStats(stats);
  REQUIRE(stats.size() == 1);
  CHECK(stats[0].at(0) == Approx(1.0));  // both agents moved
}

TEST_CASE("Field model: same_cell MDE examines the pairs inside one cost cell, wherever the swarm is", "[field]") {
  // cost cells of 2.5 m (4 per axis over 10 m; with 4 agents the bins are the cost cells themselves). Two
  // pairs 0.15 m apart: (4.9, 5.05) straddles the cells' border at x = 5 and (5.4, 5.55) lies inside the cell
  // [5, 7.5). The paper's rule separates only the second; "neighbours" separates both. (Bins that start at the
  // swarm's bounding box, as before 2026-12-07, put 4.9 and 5.05 in one bin.)
  const float xs[4] = {4.9f, 5.05f, 5.4f, 5.55f}, ys[4] = {5.3f, 5.3f, 8.3f, 8.3f};
  for (const std::string pairs : {"same_cell", "neighbours"}) {
    INFO("mde_pairs " << pairs);
    Json j = smallField({{"min_distance", 0.3}, {"mde_pairs", pairs}, {"cost_cells", {4, 4, 4}}}, 4);
    const Scenario sc = swarmsim::parseScenario(j, "bins.json");
    Simulation sim(sc);
    swarmsim::SwarmState s = sim.swarms()[0];
    for (std::size_t i = 0; i < 4; ++i) {
      s.px[i] = xs[i];
      s.py[i] = ys[i];
      s.pz[i] = 5.3f;
      s.vx[i] = s.vy[i] = s.vz[i] = 0.0f;
      s.id[i] = static_cast<std::uint32_t>(i);
    }
    const auto model = sc.swarms[0].config->build(sim.world());
    model->step(sim.world(), s, swarmsim::StepInfo{});
    Eigen::Vector3f at[4];
    for (std::size_t i = 0; i < 4; ++i) at[s.id[i]] = s.position(i);
    const float straddling = (at[0] - at[1]).norm(), inside = (at[2] - at[3]).norm();
    CHECK(inside == Approx(0.3).margin(1e-5));
    if (pairs == "same_cell") {
      CHECK(straddling == Approx(0.15).margin(1e-5));
    } else {
      CHECK(straddling == Approx(0.3).margin(1e-5));
    }
  }
}

TEST_CASE("Field model: agents descend the cost field to a goal", "[field]") {
  Json j = smallField({{"goals", {{{"type", "sphere"}, {"center", {8, 8, 8}}, {"radius", 1.0}}}}}, 50);
  j["swarms"][0]["spawn"] = {{"type", "sphere"}, {"center", {2, 2, 2}}, {"radius", 1}};
  const Scenario sc = swarmsim::parseScenario(j, "goal.json");
  Simulation sim(sc);
  for (int k = 0; k < 300; ++k) sim.step();  // 15 s at 1 m/s; the path is ~8.7 m
  const auto& s = sim.swarms()[0];
  for (std::size_t i = 0; i < s.size(); ++i) {
    CHECK((s.position(i).cast<double>() - Eigen::Vector3d(8, 8, 8)).norm() < 1.0 + 0.5);
  }
}

TEST_CASE("Field model: phototaxis draws moths toward the light", "[field]") {
  // pure noise (no goal) with and without phototaxis; the mean distance to the light must drop with it
  const auto meanDistance = [](bool photo) {
    Json params = {{"noise", {{"gain", 0.5}, {"scale", 0.5}}}};
    if (photo) params["phototaxis"] = {{"light", {9, 9, 9}}, {"probability", 0.5}, {"speed", 2.0}};
    Json j = smallField(params, 100);
    j["swarms"][0]["spawn"] = {{"type", "sphere"}, {"center", {3, 3, 3}}, {"radius", 1}};
    const Scenario sc = swarmsim::parseScenario(j, "photo.json");
    Simulation sim(sc);
    for (int k = 0; k < 60; ++k) sim.step();
    double sum = 0;
    const auto& s = sim.swarms()[0];
    for (std::size_t i = 0; i < s.size(); ++i) sum += (s.position(i).cast<double>() - Eigen::Vector3d(9, 9, 9)).norm();
    return sum / static_cast<double>(s.size());
  };
  const double without = meanDistance(false), with = meanDistance(true);
  CHECK(with < without - 2.0);  // 60 steps of 0.05 s, half of them with +2 m/s: ~3 m closer
}

TEST_CASE("Field model: results do not depend on the thread count", "[field][determinism]") {
  Scenario sc = swarmsim::loadScenario(kScenarios + "crossing.json", {"frames=3"});
  const auto run = [&](int threads) {
    swarmsim::setThreadCount(threads);
    Simulation sim(sc);
    for (int k = 0; k < 40; ++k) sim.step();
    std::vector<float> out;
    for (const auto& s : sim.swarms()) {
      // by id, whatever order the model keeps agents in
      std::vector<float> byId(3 * s.size());
      for (std::size_t i = 0; i < s.size(); ++i) {
        for (int a = 0; a < 3; ++a) byId[3 * s.id[i] + a] = s.position(i)[a];
      }
      out.insert(out.end(), byId.begin(), byId.end());
    }
    return out;
  };
  const int saved = swarmsim::threadCount();
  const auto one = run(1), two = run(2), three = run(3);
  swarmsim::setThreadCount(saved);
  REQUIRE(one.size() == two.size());
  CHECK(std::memcmp(one.data(), two.data(), one.size() * sizeof(float)) == 0);
  CHECK(std::memcmp(one.data(), three.data(), one.size() * sizeof(float)) == 0);
}

TEST_CASE("Field model: every lane set gives the same bits", "[field][determinism]") {
  // crossing: curl noise and goals (each velocity one sample of the combined field, records written on lanes
  // where AVX is there), and phototaxis (the scalar path for each agent)
  for (const char* name : {"crossing", "phototaxis"}) {
    Scenario sc = swarmsim::loadScenario(kScenarios + name + ".json", {"frames=3"});
    const auto run = [&](const char* var, const char* value) {
      const swarmsim_test::EnvGuard lanes(var, value);
      Simulation sim(sc);
      for (int k = 0; k < 30; ++k) sim.step();
      std::vector<float> out;
      for (const auto& s : sim.swarms()) {
        for (std::size_t i = 0; i < s.size(); ++i) {
          for (const float v : {s.px[i], s.py[i], s.pz[i], s.vx[i], s.vy[i], s.vz[i]}) out.push_back(v);
          float id;
          std::memcpy(&id, &s.id[i], sizeof id);
          out.push_back(id);
        }
      }
      return out;
    };
    const auto want = run("SWARMSIM_NO_AVX", "1");  // the SSE lanes
    const std::pair<const char*, const char*> modes[] = {
        {"SWARMSIM_NO_AVX2", "1"}, {"SWARMSIM_NO_AVX512", "1"}, {"SWARMSIM_NO_AVX512", nullptr}};
    for (const auto& [var, value] : modes) {
      INFO(name << ", " << var << "=" << (value ? value : "(unset)"));
      const auto got = run(var, value);
      REQUIRE(got.size() == want.size());
      CHECK(std::memcmp(got.data(), want.data(), got.size() * sizeof(float)) == 0);
    }
  }
}

TEST_CASE("Field scenarios: no agent ends inside an obstacle", "[field][scenario]") {
  for (const char* name : {"two_blocks", "min_cost_paths", "chasing", "aggregation", "phototaxis", "locusts", "crossing"}) {
    SECTION(name) {
      const Scenario sc = swarmsim::loadScenario(kScenarios + name + ".json");
      Simulation sim(sc);
      const auto sdf = fineDistance(sc, 0.25 * sc.domain.extent().minCoeff() / 40.0);
      double worst = 1e30;
      for (int k = 0; k < 240; ++k) {
        sim.step();
        if (k % 40 != 39) continue;
        for (const auto& s : sim.swarms()) {
          for (std::size_t i = 0; i < s.size(); ++i) worst = std::min<double>(worst, sdf.sample(s.position(i)));
        }
      }
      INFO(name << ": smallest signed distance to an obstacle " << worst << " m");
      CHECK(worst >= 0.0);
    }
  }
}

TEST_CASE("Field scenarios: the two_blocks swarm reaches its goal", "[field][scenario]") {
  const Scenario sc = swarmsim::loadScenario(kScenarios + "two_blocks.json");
  Simulation sim(sc);
  runWhole(sim, sc);
  const double f = insideFraction(sim.swarms()[0], {48, 10, 2}, {54, 20, 10});
  INFO("fraction inside the goal box at the end: " << f);
  CHECK(f >= 0.9);
}

TEST_CASE("Field scenarios: crossing swarms both arrive", "[field][scenario]") {
  const Scenario sc = swarmsim::loadScenario(kScenarios + "crossing.json");
  Simulation sim(sc);
  runWhole(sim, sc);
  const auto goalOf = [&](std::size_t i) {
    const Json& g = sc.resolved["swarms"][i]["params"]["goals"][0];
    return std::make_pair(Eigen::Vector3d(g["min"][0], g["min"][1], g["min"][2]),
                          Eigen::Vector3d(g["max"][0], g["max"][1], g["max"][2]));
  };
  for (std::size_t i = 0; i < 2; ++i) {
    const auto [lo, hi] = goalOf(i);
    const double f = insideFraction(sim.swarms()[i], lo, hi);
    INFO(sc.swarms[i].name << ": fraction in its goal " << f);
    CHECK(f >= 0.8);
  }
}

TEST_CASE("Field scenarios: a moving goal re-solves the cost field", "[field][scenario]") {
  const Scenario sc = swarmsim::loadScenario(kScenarios + "chasing.json");
  Simulation sim(sc);
  for (int k = 0; k < 600; ++k) sim.step();
  const Json info = sim.model(0).benchInfo();
  CHECK(info.at("cost_solves").get<long long>() > 2);
}

TEST_CASE("Field scenarios: the noise baselines run on two_blocks", "[field][scenario]") {
  for (const char* type : {"curl", "perlin", "white"}) {
    SECTION(type) {
      const Scenario sc = swarmsim::loadScenario(kScenarios + "two_blocks.json",
                                                 {std::string("swarms[0].params.noise.type=") + type});
      Simulation sim(sc);
      for (int k = 0; k < 60; ++k) sim.step();
      const auto& s = sim.swarms()[0];
      for (std::size_t i = 0; i < s.size(); ++i) REQUIRE(s.position(i).allFinite());
    }
  }
}

TEST_CASE("Field model: cost_order 2 is the second-order solve; other orders are refused", "[field]") {
  // the agents still reach the goal with the second-order cost field, and the model reports the order's
  // field: one step from the same start differs from the first-order one (a different C near the agents)
  Json j = smallField({{"goals", {{{"type", "sphere"}, {"center", {8, 8, 8}}, {"radius", 1.0}}}}}, 50);
  j["swarms"][0]["spawn"] = {{"type", "sphere"}, {"center", {2, 3, 2}}, {"radius", 1}};
  Json j2 = j;
  j2["swarms"][0]["params"]["cost_order"] = 2;
  Simulation sim1(swarmsim::parseScenario(j, "order1.json")), sim2(swarmsim::parseScenario(j2, "order2.json"));
  sim1.step();
  sim2.step();
  CHECK(sim1.swarms()[0].vx != sim2.swarms()[0].vx);
  for (int k = 1; k < 300; ++k) sim2.step();
  const auto& s = sim2.swarms()[0];
  for (std::size_t i = 0; i < s.size(); ++i) {
    CHECK((s.position(i).cast<double>() - Eigen::Vector3d(8, 8, 8)).norm() < 1.0 + 0.5);
  }
  for (const int bad : {0, 3}) {
    Json b = j;
    b["swarms"][0]["params"]["cost_order"] = bad;
    try {
      swarmsim::parseScenario(b, "bad.json");
      FAIL("cost_order " << bad << " was accepted");
    } catch (const swarmsim::InputError& e) {
      CHECK(std::string(e.what()).find("cost_order") != std::string::npos);
    }
  }
}
