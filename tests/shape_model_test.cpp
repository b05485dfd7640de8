// The shape-constrained model (lib/models/shape, chen2019): eq. 5 and eq. 6 against
// hand-worked values, F_dis's shape (zero at the target, toward it everywhere in
// range), the B-spline path against its closed form.
#include <algorithm>
#include <array>
#include <catch2/catch.hpp>
#include <cmath>
#include <cstring>
#include <random>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "io/scenario.hpp"
#include "models/field/mde.hpp"
#include "models/shape/path.hpp"
#include "models/shape/shape.hpp"
#include "run.hpp"

using Catch::Detail::Approx;
using swarmsim::Vec3;
using swarmsim::Vec3d;

TEST_CASE("shape: the distance profile of eq. 6-7", "[shape]") {
  // 4 (d - 0.5)^3 + 0.5 on (0, 1], 0 elsewhere (H = 0 outside the normalised range)
  CHECK(swarmsim::distanceProfile(0.0f) == 0.0f);
  CHECK(swarmsim::distanceProfile(0.25f) == Approx(0.4375));  // 4 (-0.25)^3 + 0.5
  CHECK(swarmsim::distanceProfile(0.5f) == Approx(0.5));
  CHECK(swarmsim::distanceProfile(0.75f) == Approx(0.5625));
  CHECK(swarmsim::distanceProfile(1.0f) == Approx(1.0));
  CHECK(swarmsim::distanceProfile(1.001f) == 0.0f);
  CHECK(swarmsim::distanceProfile(-0.5f) == 0.0f);
  // near the target it grows like 3 d (the cubic's slope at 0 is 12 * 0.25 = 3)
  CHECK(swarmsim::distanceProfile(1e-3f) == Approx(3e-3).epsilon(0.01));
}

TEST_CASE("shape: F_dis (eq. 6) by hand, zero at the target and toward it in range", "[shape]") {
  // x at the origin, s at (3, 4, 0): distance 5, range 10 -> d = 0.5, profile 0.5; w_dis 4 -> |F| = 2 along (0.6, 0.8, 0)
  const Vec3 f = swarmsim::distanceForce(Vec3(0, 0, 0), Vec3(3, 4, 0), 4.0f, 0.1f);
  CHECK(f.x() == Approx(1.2));
  CHECK(f.y() == Approx(1.6));
  CHECK(f.z() == Approx(0.0).margin(1e-7));
  // range 5: d = 1 -> profile 1, |F| = 4
  CHECK(swarmsim::distanceForce(Vec3(0, 0, 0), Vec3(3, 4, 0), 4.0f, 0.2f).norm() == Approx(4.0));
  // beyond the range: none
  CHECK(swarmsim::distanceForce(Vec3(0, 0, 0), Vec3(3, 4, 0), 4.0f, 0.5f).norm() == 0.0f);
  // at the target: zero
  CHECK(swarmsim::distanceForce(Vec3(1, 2, 3), Vec3(1, 2, 3), 4.0f, 0.1f).norm() == 0.0f);
  // toward the target everywhere in range
  std::mt19937 gen(5);
  std::uniform_real_distribution<float> u(-6.0f, 6.0f);
  const Vec3 s(0.5f, -1.0f, 2.0f);
  int inRange = 0;
  for (int i = 0; i < 2000; ++i) {
    const Vec3 x = s + Vec3(u(gen), u(gen), u(gen));
    const Vec3 fd = swarmsim::distanceForce(x, s, 4.0f, 1.0f / 8.0f);
    if ((x - s).norm() <= 8.0f) {
      ++inRange;
      REQUIRE(fd.norm() > 0.0f);
      CHECK(fd.normalized().dot((s - x).normalized()) == Approx(1.0).margin(1e-5));
    } else {
      CHECK(fd.norm() == 0.0f);
    }
  }
  CHECK(inRange > 1000);
}

TEST_CASE("shape: F_con (eq. 5) by hand", "[shape]") {
  // threshold k h = 0.8 (Manhattan), sigma = 0.36 (omega 0.9 of h 0.4)
  swarmsim::ShapeConstraintSum con(0.8f, 0.36f);
  con.add(0.1f, 0.0f, 0.0f, 0.01f);   // M 0.1: weight exp(-0.01 / 0.2592) = 0.962155, away = (-1, 0, 0)
  con.add(0.0f, -0.2f, 0.0f, 0.04f);  // M 0.2: weight exp(-0.04 / 0.2592) = 0.856997, away = (0, 1, 0)
  con.add(0.3f, 0.3f, 0.3f, 0.27f);   // M 0.9 >= 0.8: not a neighbour (its Euclidean 0.52 would be)
  con.add(0.0f, 0.0f, 0.0f, 0.0f);    // the insect's own position: skipped
  REQUIRE(con.count == 2);
  const Vec3 f = con.force(1.0f);
  CHECK(f.x() == Approx(-0.962155 / 2).epsilon(1e-5));
  CHECK(f.y() == Approx(0.856997 / 2).epsilon(1e-5));
  CHECK(f.z() == Approx(0.0).margin(1e-7));
  CHECK(con.force(3.0f).x() == Approx(3.0 * -0.962155 / 2).epsilon(1e-5));
  // no neighbours: no force
  swarmsim::ShapeConstraintSum none(0.8f, 0.36f);
  CHECK(none.force(1.0f).norm() == 0.0f);
}

TEST_CASE("shape: cubic B-spline path, arc length", "[shape]") {
  SECTION("four points: a cubic Bezier; equally spaced collinear points give a uniform line") {
    const swarmsim::BSplinePath p({Vec3d(0, 0, 0), Vec3d(1, 0, 0), Vec3d(2, 0, 0), Vec3d(3, 0, 0)});
    CHECK(p.length() == Approx(3.0).epsilon(1e-9));
    for (double s : {0.0, 0.4, 1.5, 2.9, 3.0}) CHECK((p.at(s) - Vec3d(s, 0, 0)).norm() < 1e-9);
    CHECK((p.tangent(1.0) - Vec3d(1, 0, 0)).norm() < 1e-9);
    CHECK((p.at(10.0) - Vec3d(3, 0, 0)).norm() < 1e-12);  // clamped
  }
  SECTION("ends are interpolated; the curve is C2 and arc length is uniform") {
    const std::vector<Vec3d> c = {Vec3d(0, 0, 0), Vec3d(5, 0, 0), Vec3d(5, 5, 1), Vec3d(0, 5, 2),
                                  Vec3d(-5, 5, 2), Vec3d(-5, 0, 0)};
    const swarmsim::BSplinePath p(c);
    CHECK((p.at(0.0) - c.front()).norm() < 1e-12);
    CHECK((p.at(p.length()) - c.back()).norm() < 1e-9);
    // equal steps of arc length are equal chords (to the chord's second-order error)
    const int steps = 400;
    const double ds = p.length() / steps;
    for (int i = 0; i < steps; ++i) {
      const double chord = (p.at((i + 1) * ds) - p.at(i * ds)).norm();
      CHECK(chord == Approx(ds).epsilon(2e-3));
    }
    // the length against an independent fine polyline of the parameterisation
    double fine = 0.0;
    Vec3d prev = p.atParameter(0.0);
    for (int i = 1; i <= 200000; ++i) {
      const Vec3d q = p.atParameter(i / 200000.0);
      fine += (q - prev).norm();
      prev = q;
    }
    CHECK(p.length() == Approx(fine).epsilon(1e-6));
  }
  SECTION("fewer control points than a cubic needs") {
    CHECK_THROWS_AS(swarmsim::BSplinePath({Vec3d(0, 0, 0), Vec3d(1, 0, 0), Vec3d(2, 0, 0)}), std::invalid_argument);
  }
}

TEST_CASE("shape: F_int (eq. 2-3) over given neighbours, by hand", "[shape]") {
  // zones: rep [0, 0.5), ali [0.5, 2), att [2, 4]; weights 1, 2, 3
  swarmsim::ZonalSum z(0.5f, 2.0f, 4.0f, 1.0f, 2.0f, 3.0f);
  z.add(0.3f, 0.0f, 0.0f, 0.09f, 1.0f, 1.0f, 0.0f);    // rep: -x
  z.add(0.0f, 1.0f, 0.0f, 1.0f, 0.0f, 0.0f, 2.0f);     // ali: toward dv, +z
  z.add(0.0f, -1.5f, 0.0f, 2.25f, 3.0f, 4.0f, 0.0f);   // ali: (0.6, 0.8, 0)
  z.add(0.0f, 0.0f, 3.0f, 9.0f, 0.0f, 0.0f, 0.0f);     // att: +z
  z.add(5.0f, 0.0f, 0.0f, 25.0f, 0.0f, 0.0f, 0.0f);    // beyond r_att: nothing
  z.add(0.0f, 0.0f, 0.0f, 0.0f, 0.0f, 0.0f, 0.0f);     // at the insect's position: counts in rep, adds 0
  const Vec3 f = z.force();
  // rep: 1 / 2 * (-1, 0, 0); ali: 2 / 2 * ((0, 0, 1) + (0.6, 0.8, 0)); att: 3 / 1 * (0, 0, 1)
  CHECK(f.x() == Approx(-0.5 + 0.6));
  CHECK(f.y() == Approx(0.8));
  CHECK(f.z() == Approx(1.0 + 3.0));
  CHECK(z.count[0] == 2);
  CHECK(z.count[1] == 2);
  CHECK(z.count[2] == 1);
}

TEST_CASE("shape: F_int acts over each insect's K nearest neighbours within r_att", "[shape]") {
  // 400 insects in a 6 m box, no noise, no target yet (its key is at 1 s), alpha 1, no MDE, no speed limit
  // to speak of: one step changes each velocity by exactly F_int dt, which the test recomputes by brute force
  const std::string mesh = std::string(SWARMSIM_SOURCE_DIR) + "/data/shapes/sphere.obj";
  // at the first step (no neighbours known yet), at the sixth and the 41st (candidates from near lists kept
  // over steps, some rebuilt); at 0.5 m/s, and at 30 m/s, where the insects move fast for their spacing and each
  // one's search is bounded by last step's K nearest
  for (const double speed : {0.5, 30.0})
    for (const int warm : {0, 5, 40})
      for (const int K : {1, 6, 40}) {
        swarmsim::Json j = {{"name", "knn"},
                            {"seed", 5u},
                            {"dt", 0.01},
                            {"frames", 200u},
                            {"steps_per_frame", 1u},
                            {"domain", {{"min", {-10, -10, -10}}, {"max", {10, 10, 10}}}},
                            {"swarms",
                             {{{"name", "flies"},
                               {"count", 400u},
                               {"model", "shape"},
                               {"initial_speed", speed},
                               {"spawn", {{"type", "box"}, {"min", {-3, -3, -3}}, {"max", {3, 3, 3}}}},
                               {"params",
                                {{"alpha", 1.0},
                                 {"neighbours", static_cast<unsigned>(K)},
                                 {"r_rep", 0.3},
                                 {"r_ali", 0.8},
                                 {"r_att", 1.5},
                                 {"w_rep", 1.0},
                                 {"w_ali", 2.0},
                                 {"w_att", 3.0},
                                 {"min_distance", 0.0},
                                 // no noise and no obstacles: coarse noise and distance grids (their set-up was nearly
                                 // all of the test's time, minutes under the sanitizers)
                                 {"noise", {{"eta", 0.0}, {"cells", {8, 8, 8}}}},
                                 {"sdf_cells", {16, 16, 16}},
                                 {"max_speed", 1000.0},
                                 {"targets", {{{"time", 1.0}, {"file", mesh}}}}}}}}}};
        const swarmsim::Scenario sc = swarmsim::parseScenario(j, "knn.json");
        swarmsim::Simulation sim(sc);
        for (int w = 0; w < warm; ++w) sim.step();
        const swarmsim::SwarmState before = sim.swarms()[0];
        sim.step();
        const swarmsim::SwarmState& after = sim.swarms()[0];
        const std::size_t n = before.size();
        std::vector<Vec3> x(n), v(n), v1(n);
        for (std::size_t i = 0; i < n; ++i) {
          x[before.id[i]] = Vec3(before.px[i], before.py[i], before.pz[i]);
          v[before.id[i]] = Vec3(before.vx[i], before.vy[i], before.vz[i]);
          v1[after.id[i]] = Vec3(after.vx[i], after.vy[i], after.vz[i]);
        }
        int checked = 0, withFew = 0;
        for (std::size_t i = 0; i < n; ++i) {
          std::vector<std::pair<float, std::size_t>> near;
          for (std::size_t o = 0; o < n; ++o) {
            if (o == i) continue;
            const Vec3 d = x[o] - x[i];
            const float d2 = d.x() * d.x() + d.y() * d.y() + d.z() * d.z();
            if (d2 <= 1.5f * 1.5f) near.emplace_back(d2, o);
          }
          std::sort(near.begin(), near.end());
          if (near.size() < static_cast<std::size_t>(K)) ++withFew;
          near.resize(std::min(near.size(), static_cast<std::size_t>(K)));
          swarmsim::ZonalSum z(0.3f, 0.8f, 1.5f, 1.0f, 2.0f, 3.0f);
          for (const auto& [d2, o] : near) {
            const Vec3 d = x[o] - x[i], dv = v[o] - v[i];
            z.add(d.x(), d.y(), d.z(), d2, dv.x(), dv.y(), dv.z());
          }
          const Vec3 expected = z.force();
          const Vec3 got = (v1[i] - v[i]) / 0.01f;
          CHECK((got - expected).norm() <= 1e-3f * std::max(1.0f, expected.norm()));
          ++checked;
        }
        CHECK(checked == 400);
        if (K == 40) CHECK(withFew > 50);  // some insects have fewer than K within r_att: all of those count
        // the fast swarm's steps after the first took the bound from last step's K nearest
        const double kept = sim.model(0).benchInfo().at("near_kept").get<double>();
        if (speed > 1.0 && warm > 0) CHECK(kept > 0.5);
        if (speed < 1.0) CHECK(kept == 0.0);
      }
}

namespace {

// 800 insects in a 6 m box forming a small sphere, with the K nearest (K = 10) and MDE: the scenario of the
// caches' tests (near lists, kept grid cells), with one speed-only key set to `value`
swarmsim::Json cacheScenario(const char* name, unsigned seed, double initialSpeed, double maxSpeed, const char* key,
                             double value) {
  const std::string mesh = std::string(SWARMSIM_SOURCE_DIR) + "/data/shapes/sphere.obj";
  return {{"name", name}, {"seed", seed}, {"dt", 0.02}, {"frames", 100u}, {"steps_per_frame", 1u},
          {"domain", {{"min", {-6, -6, -6}}, {"max", {6, 6, 6}}}},
          {"swarms",
           {{{"name", "flies"}, {"count", 800u}, {"model", "shape"}, {"initial_speed", initialSpeed},
             {"spawn", {{"type", "box"}, {"min", {-3, -3, -3}}, {"max", {3, 3, 3}}}},
             {"params",
              {{"alpha", 0.5}, {"neighbours", 10u}, {"r_rep", 0.2}, {"r_ali", 0.6}, {"r_att", 2.0}, {"w_att", 1.0},
               {"min_distance", 0.05}, {"max_speed", maxSpeed}, {key, value},
               {"targets", {{{"time", 0.0}, {"file", mesh}, {"scale", 0.25}}}}}}}}}};
}

// each insect's position and velocity, by id (the state's order is the grid's, which may differ)
std::vector<std::array<float, 6>> byId(const swarmsim::SwarmState& st) {
  std::vector<std::array<float, 6>> out(st.size());
  for (std::size_t i = 0; i < st.size(); ++i) out[st.id[i]] = {st.px[i], st.py[i], st.pz[i], st.vx[i], st.vy[i], st.vz[i]};
  return out;
}

}  // namespace

TEST_CASE("shape: a swarm travelling together keeps its near lists; they stay a cache", "[shape]") {
  // The near lists measure each step's moves against a translation common to the whole swarm (the middle of
  // the moves' bounding box; near_list.hpp): what decides whether a list still holds is how the insects move
  // relative to each other. Here a ball of 800 insects is pulled along a path at 6 m/s (12 cm a step, against
  // lists built about 10 % beyond the K-th distance of ~0.5 m): measured from a fixed frame, every list would
  // be out of date every step. A new list every step (skin 0) gives the same bits.
  const std::string mesh = std::string(SWARMSIM_SOURCE_DIR) + "/data/shapes/sphere.obj";
  const auto run = [&](double skin, double& rebuilds) {
    const swarmsim::Json j = {
        {"name", "travel"},
        {"seed", 11u},
        {"dt", 0.02},
        {"frames", 120u},
        {"steps_per_frame", 1u},
        {"domain", {{"min", {-6, -6, -6}}, {"max", {60, 6, 6}}}},
        {"swarms",
         {{{"name", "flies"},
           {"count", 800u},
           {"model", "shape"},
           {"initial_speed", 0.5},
           {"spawn", {{"type", "box"}, {"min", {-3, -3, -3}}, {"max", {3, 3, 3}}}},
           {"params",
            {{"alpha", 0.5},
             {"neighbours", 10u},
             {"r_rep", 0.2},
             {"r_ali", 1.0},
             {"r_att", 2.0},
             {"w_ali", 8.0},
             {"w_att", 1.0},
             {"w_dis", 50.0},
             {"distance_range", 6.0},
             {"min_distance", 0.05},
             {"max_speed", 12.0},
             {"list_skin", skin},
             {"targets", {{{"time", 0.0}, {"file", mesh}, {"scale", 0.25}}}},
             {"path",
              {{"points", {{0, 0, 0}, {10, 0, 0}, {20, 0, 0}, {30, 0, 0}}}, {"speed", 6.0}, {"start", 1.0}}}}}}}}};
    swarmsim::Simulation sim(swarmsim::parseScenario(j, "travel.json"));
    for (int s = 0; s < 70; ++s) sim.step();
    sim.restartBenchTimers();  // from here the swarm travels
    for (int s = 0; s < 40; ++s) sim.step();
    const swarmsim::Json info = sim.model(0).benchInfo();
    rebuilds = info["list_rebuilds"].get<double>();
    return sim.swarms()[0];
  };
  double r0 = 0.0, r1 = 0.0;
  const swarmsim::SwarmState a = run(0.0, r0), b = run(0.3, r1);
  INFO("lists built per insect-step: " << r0 << ", " << r1);
  // travelling: the ball's mean x moved on by several metres in the 40 steps (6 m/s: 4.8 m at full speed)
  double meanX = 0.0;
  for (std::size_t i = 0; i < b.size(); ++i) meanX += b.px[i];
  meanX /= static_cast<double>(b.size());
  CHECK(meanX > 2.0);
  REQUIRE(b.size() == a.size());
  CHECK(byId(b) == byId(a));
  CHECK(r0 > 0.99);
  CHECK(r1 < 0.6);  // (from a fixed frame: 0.99, measured with the earlier bound)
}

TEST_CASE("shape: keeping the grid's cells across steps is a cache: any grid_drift gives the same bits", "[shape]") {
  // With the K nearest, the grid keeps its cells while the insects have moved less than grid_drift cells
  // since it was built (UniformGrid::moveSorted); its queries reach that much farther. No sum depends on the
  // grid, so a new grid every step (0), the default and a wide drift give bit-identical states, with very
  // different numbers of grids built. Fast insects (1.5 m/s, 3 cm a step) leave their cells within a few steps.
  const auto run = [&](double drift, double& builds) {
    const swarmsim::Json j = cacheScenario("drift", 13u, 1.0, 1.5, "grid_drift", drift);
    swarmsim::Simulation sim(swarmsim::parseScenario(j, "drift.json"));
    for (int s = 0; s < 60; ++s) sim.step();
    builds = sim.model(0).benchInfo()["grid_builds"].get<double>();
    return sim.swarms()[0];
  };
  double b0 = 0.0, b1 = 0.0, b2 = 0.0;
  const swarmsim::SwarmState a = run(0.0, b0), b = run(0.25, b1), c = run(1.5, b2);
  INFO("grids built per step: " << b0 << ", " << b1 << ", " << b2);
  // the state is kept in the grid's order, which differs: compare insect by insect (by id)
  const auto ref = byId(a);
  for (const swarmsim::SwarmState* o : {&b, &c}) {
    REQUIRE(o->size() == a.size());
    CHECK(byId(*o) == ref);
  }
  CHECK(b0 == 1.0);  // every step
  CHECK(b1 < 0.8);
  CHECK(b1 > 0.05);  // the default rebuilds now and then: the insects drift out of the cells
  CHECK(b2 < b1);
}

TEST_CASE("shape: the near lists are a cache: any skin gives the same bits", "[shape]") {
  // F_con, F_int over the K nearest and MDE all take their candidates from per-insect lists kept across steps
  // (near_list.hpp). Each sum runs over only the entries that count, in id order, so the result must not
  // depend on when a list was built: skin 0 (a new list every step), the default, and a wide skin (lists
  // often too long to keep: the grid's candidates serve that step, MDE's included) give bit-identical
  // states, while building very different numbers of lists.
  const auto run = [&](double skin, double& rebuilds) {
    const swarmsim::Json j = cacheScenario("lists", 11u, 0.5, 0.5, "list_skin", skin);
    swarmsim::Simulation sim(swarmsim::parseScenario(j, "lists.json"));
    for (int s = 0; s < 80; ++s) sim.step();
    const swarmsim::Json info = sim.model(0).benchInfo();
    rebuilds = info["list_rebuilds"].get<double>();
    // where a step's time goes (bench's shape columns): each part timed, in ms per step
    for (const char* part : {"ms_grid", "ms_noise", "ms_forces", "ms_mde"}) {
      INFO(part);
      CHECK(info.at(part).get<double>() > 0.0);
      CHECK(info.at(part).get<double>() < 1e3);
    }
    return sim.swarms()[0];
  };
  double r0 = 0.0, r1 = 0.0, r2 = 0.0;
  const swarmsim::SwarmState a = run(0.0, r0), b = run(0.3, r1), c = run(0.8, r2);
  INFO("lists built per insect-step: " << r0 << ", " << r1 << ", " << r2);
  const auto ref = byId(a);
  for (const swarmsim::SwarmState* o : {&b, &c}) {
    REQUIRE(o->size() == a.size());
    CHECK(byId(*o) == ref);
  }
  // lists built per insect and step: every one with no skin, a few with the default, more again when wide
  CHECK(r0 > 0.99);
  CHECK(r1 < 0.2);
  CHECK(r2 > 2.0 * r1);
}

TEST_CASE("shape: MDE pushes each insect from the neighbours nearer than d_min after the move, and only those",
          "[shape]") {
  // A dense swarm gathering on a small sphere: after each of a few steps, every insect is where the one-insect
  // computation puts it: t = x + v' dt (v' the new velocity), plus MDE's push from the insects whose t is nearer
  // than d_min (in id order, as listPush adds them), or t + 0 when there are none. Exact bits. Fast insects
  // (10 m/s, 0.2 m a step) have many candidates within MDE's reach (d_min + 2 max speed dt).
  const float dt = 0.02f, md = 0.3f, vmax = 10.0f, reach = md + 2.0f * vmax * dt;
  swarmsim::Json scenario = cacheScenario("mde", 3u, 0.5, vmax, "list_skin", 0.3);
  scenario["swarms"][0]["params"]["min_distance"] = md;
  const swarmsim::Scenario sc = swarmsim::parseScenario(scenario, "mde.json");
  swarmsim::Simulation sim(sc);
  for (int w = 0; w < 60; ++w) sim.step();
  std::size_t pushed = 0, checked = 0, coincident = 0, crowded = 0;
  for (int s = 0; s < 6; ++s) {
    const auto before = byId(sim.swarms()[0]);
    sim.step();
    const auto after = byId(sim.swarms()[0]);
    const std::size_t n = before.size();
    std::vector<float> tx(n), ty(n), tz(n);
    for (std::size_t i = 0; i < n; ++i) {
      tx[i] = before[i][0] + after[i][3] * dt;
      ty[i] = before[i][1] + after[i][4] * dt;
      tz[i] = before[i][2] + after[i][5] * dt;
    }
    for (std::size_t i = 0; i < n; ++i) {
      std::vector<float> nx, ny, nz;
      std::size_t near = 0;                  // insects within MDE's reach at the step's start, so far
      for (std::size_t j = 0; j < n; ++j) {  // (ids ascending)
        const float dx = tx[j] - tx[i], dy = ty[j] - ty[i], dz = tz[j] - tz[i];
        const float d2 = dx * dx + dy * dy + dz * dz;
        coincident += j != i && d2 == 0.0f ? 1 : 0;
        const float sx = before[j][0] - before[i][0], sy = before[j][1] - before[i][1],
                    sz = before[j][2] - before[i][2];
        near += j != i && sx * sx + sy * sy + sz * sz <= reach * reach ? 1 : 0;
        if (d2 < md * md && d2 > 0.0f) {
          nx.push_back(tx[j]);
          ny.push_back(ty[j]);
          nz.push_back(tz[j]);
          crowded += near > 6 ? 1 : 0;
        }
      }
      Vec3 want(tx[i], ty[i], tz[i]);
      swarmsim::MdePush kernel(md);
      kernel.start(tx[i], ty[i], tz[i]);
      kernel.add(nx.data(), ny.data(), nz.data(), 0, static_cast<std::uint32_t>(nx.size()));
      want += kernel.push();
      pushed += nx.empty() ? 0 : 1;
      CAPTURE(s, i, nx.size());
      for (int a = 0; a < 3; ++a)
        CHECK(std::memcmp(&after[i][static_cast<std::size_t>(a)], &want[a], sizeof(float)) == 0);
      ++checked;
    }
  }
  CHECK(checked == 6 * 800);
  CHECK(coincident == 0);  // (no exactly coincident pair, which MDE separates along x)
  CHECK(pushed > 200);     // (the test has pushes to check)
  CHECK(crowded > 50);     // (and pushes from beyond the sixth insect within MDE's reach: long candidate lists)
}
